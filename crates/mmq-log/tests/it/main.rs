//! Integration tests of mmq-log, one module per topic.

mod common;
mod compare;
mod estimates;
mod fuzz_props;
mod honest;
mod live;
mod render;
mod robot;
mod roundtrip;
mod schemas;
mod served;
mod stalled;
mod swarm;
mod truncation;
