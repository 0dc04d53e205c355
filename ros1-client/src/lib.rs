//! A ROS 1 client, enough for a robot's program to read its topics straight from a ROS 1
//! master with no bridge: a subscribing node that survives its master and its publishers
//! going away ([`Node`]), on `xmlrpc` (the master and node APIs' messages) and `tcpros`
//! (the topic transport). It hands each message's bytes to the caller; reading them is the
//! caller's (the agent's `ros_msg`).
//!
//! Why a client of our own: `roslibrust` (its `ros1` feature, 0.26) reads the same topics
//! from Debian's real master, but when the master restarts it never registers again (its
//! subscriptions stay silent with no error the caller could see), it fails at once when the
//! master is not up yet, and it links OpenSSL (through `reqwest`'s default TLS), which the
//! robot's static cross build would have to carry. The agent's real-master test
//! (`tests/miro/ros1.sh`) restarts the master and expects the agent to read again.

mod node;
mod tcpros;
mod xmlrpc;

pub use node::{CHECK_PERIOD, Node, NodeConfig, NodeCounts, Ros1Error, TopicSpec};
