//! System tests and the evaluation harness: the simulated world against the fusion core,
//! the seed's method and an oracle, scored against ground truth.

pub mod baseline;
pub mod bench;
pub mod eval;
pub mod methods;
pub mod plot;
pub mod plots;
pub mod report;
pub mod vision;
pub mod vision_report;
