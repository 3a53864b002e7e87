//! The workspace's end-to-end tests, one module per topic, in one test binary (one link
//! of the whole lab instead of one per topic): the `mmq` binary's commands, its output
//! folders and worlds, interruption and hostile inputs, the paper's report, sweeps, the
//! suite, the swarm, a diagnostic learner, and the code's shape (layering, no prints in libraries, no module
//! cycles). `cargo test --test it MODULE::` runs one topic.

mod architecture;
mod cli;
mod common;
mod import_cycles;
mod limits;
mod paper;
mod paper_resume;
mod reference;
mod robustness;
mod served;
mod suite;
mod swarm;
mod sweep;
mod told_cells;
mod write_failures;
