//! Integration tests of mmq-core, one module per topic, in one test binary: property-based
//! fuzzing of the parsers, and delays in seconds.

mod fuzz_props;
mod seconds;
