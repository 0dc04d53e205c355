//! A ROS 1 client of the agent's own, enough to read a MiRo's topics straight from its
//! master with no bridge: [`xmlrpc`] (the master and node APIs' messages), [`tcpros`] (the
//! topic transport) and [`node`] (a subscribing node that survives its master and its
//! publishers going away). The messages' bytes are read by [`crate::io::ros_msg`].

mod node;
mod tcpros;
mod xmlrpc;

pub use node::{Node, NodeConfig, TopicSpec};
