//! Integration tests of mmq-lab, one module per topic, in one test binary: the paper's
//! figure specs, and recording with verification.

mod paper_specs;
mod record;
