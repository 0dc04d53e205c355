//! `--source ros1`: a running MiRo's topics read straight from its ROS 1 master (no bridge),
//! through the ROS 1 client's node ([`ros1_client`]). The topics and what becomes of
//! their messages are those of the Zenoh bridge's source ([`RosInbox`]).

use crate::io::ros_msg::Encoding;
use crate::runtime::frame::StoredFrame;
use crate::runtime::live_ros::{RosFrames, RosInbox, RosRole};
use crate::runtime::ros_frames::RosTopics;
use crate::runtime::source::FrameSource;
use anyhow::{Context, Result};
use ros1_client::{Node, NodeConfig, TopicSpec};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// The master's URI when neither `--ros-master-uri` nor `ROS_MASTER_URI` gives one.
pub const DEFAULT_MASTER_URI: &str = "http://localhost:11311";

/// The master's URI: the flag's, else `ROS_MASTER_URI`, else [`DEFAULT_MASTER_URI`].
pub fn master_uri(flag: Option<&str>) -> String {
    flag.map(str::to_string)
        .or_else(|| std::env::var("ROS_MASTER_URI").ok())
        .filter(|u| !u.trim().is_empty())
        .unwrap_or_else(|| DEFAULT_MASTER_URI.to_string())
}

/// The node's name for a robot (`/robot_agent_miro1`): ROS names take no `-`.
pub fn node_name(robot_id: &str) -> String {
    format!("/robot_agent_{}", robot_id.replace('-', "_"))
}

/// The types a topic of this role may carry.
fn types(role: RosRole) -> Vec<String> {
    match role {
        RosRole::Image(_) => vec!["sensor_msgs/CompressedImage".into()],
        RosRole::Joints => vec!["sensor_msgs/JointState".into()],
        RosRole::Pose(_) => vec!["geometry_msgs/Pose2D".into(), "nav_msgs/Odometry".into()],
    }
}

/// A MiRo's camera, joint and pose topics from its ROS 1 master.
pub struct Ros1Source {
    frames: RosFrames,
    node: Node,
}

impl std::fmt::Debug for Ros1Source {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Ros1Source")
            .field("node", &self.node)
            .finish()
    }
}

impl Ros1Source {
    /// Starts the node; the master may come later (the node keeps asking).
    pub async fn open(topics: &RosTopics, robot_id: &str, stop: Arc<AtomicBool>) -> Result<Self> {
        let uri = master_uri(topics.ros_master_uri.as_deref());
        let (inbox, frames) = RosInbox::new(topics, Encoding::Ros1, stop);
        let roles = RosInbox::roles(topics);
        let specs = roles
            .iter()
            .map(|(name, role)| TopicSpec {
                name: name.clone(),
                types: types(*role),
            })
            .collect();
        let deliver_roles: Vec<RosRole> = roles.iter().map(|(_, r)| *r).collect();
        let deliver = Arc::new(move |i: usize, bytes: &[u8]| {
            if let Some(role) = deliver_roles.get(i) {
                inbox.receive(*role, bytes);
            }
        });
        let config = NodeConfig {
            master_uri: uri.clone(),
            caller_id: node_name(robot_id),
            host: None,
        };
        let node = Node::start(config, specs, deliver)
            .await
            .with_context(|| format!("starting the ROS 1 node for master {uri}"))?;
        tracing::info!(
            "ROS 1 node {} at {}: waiting for frames on {} and {} from master {uri}",
            node_name(robot_id),
            node.caller_api,
            topics.left_topic,
            topics.right_topic
        );
        Ok(Ros1Source { frames, node })
    }
}

impl FrameSource for Ros1Source {
    fn next_frame(&mut self) -> Result<Option<StoredFrame>> {
        self.frames.next_frame()
    }

    fn live(&self) -> bool {
        true
    }
}

impl Drop for Ros1Source {
    fn drop(&mut self) {
        let c = &self.node.counts;
        tracing::info!(
            "ROS 1 node: {} messages over {} connections, {} publishers refused",
            c.messages.load(Ordering::Relaxed),
            c.connections.load(Ordering::Relaxed),
            c.refused.load(Ordering::Relaxed)
        );
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn names_and_uris() {
        assert_eq!(node_name("miro-1"), "/robot_agent_miro_1");
        assert_eq!(master_uri(Some("http://robot:11311")), "http://robot:11311");
    }
}
