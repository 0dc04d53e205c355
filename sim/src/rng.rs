//! The simulator's random numbers: the workspace's seeded generators (`proto::rng`), under
//! the name the simulator's modules use.

pub use proto::rng::*;
