//! A deterministic, dependency-free fuzzer over every decoder and validator of the
//! products: proto's messages and keys, the fusion server's engine, queries, settings and
//! match logs, and the robot agent's ROS messages, label files and images.
//!
//! Each [`Target`] builds its own valid seed inputs; [`mutate::generate`] turns them (or
//! nothing) into hostile inputs, and [`runner::run`] feeds them to the target under
//! `catch_unwind`. A panic, or a broken invariant asserted by the target, is a finding.

pub mod agent_targets;
pub mod mutate;
pub mod proto_targets;
pub mod runner;
pub mod seeds;
pub mod server_targets;

/// What a target made of one input.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// The product accepted (decoded, validated) the input.
    Accepted,
    /// The product refused it with an error.
    Rejected,
}

impl Verdict {
    /// `Accepted` when `ok`.
    pub fn of(ok: bool) -> Self {
        if ok {
            Verdict::Accepted
        } else {
            Verdict::Rejected
        }
    }
}

/// Runs one input and says what the product made of it.
pub type Check = Box<dyn FnMut(&[u8]) -> Verdict>;

/// One decoder or validator under test, with its valid seeds.
pub struct Target {
    pub name: &'static str,
    /// Valid inputs the mutations start from.
    pub seeds: Vec<Vec<u8>>,
    /// Runs one input; panics (or failed assertions on its output) are findings.
    pub check: Check,
}

impl std::fmt::Debug for Target {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Target")
            .field("name", &self.name)
            .field("seeds", &self.seeds.len())
            .finish_non_exhaustive()
    }
}

impl Target {
    pub fn new(
        name: &'static str,
        seeds: Vec<Vec<u8>>,
        check: impl FnMut(&[u8]) -> Verdict + 'static,
    ) -> Self {
        Target {
            name,
            seeds,
            check: Box::new(check),
        }
    }
}

/// Every target, in a fixed order.
pub fn all_targets() -> Vec<Target> {
    let mut targets = proto_targets::targets();
    targets.extend(server_targets::targets());
    targets.extend(agent_targets::targets());
    targets
}

/// The names of every target.
pub fn target_names() -> Vec<&'static str> {
    all_targets().iter().map(|t| t.name).collect()
}
