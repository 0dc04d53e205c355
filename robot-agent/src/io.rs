//! Files and messages: [`image_io`] loads images from JPEG and PNG files and writes PNGs;
//! [`ros_msg`] decodes the ROS messages of a MiRo's recordings (compressed images, joint
//! states, poses, odometry) from ROS 1 and ROS 2 (CDR) bytes (the `ros1-client` crate reads
//! them live from a ROS 1 master).

pub mod image_io;
pub mod ros_msg;
#[cfg(any(test, feature = "test-support"))]
pub mod ros_msg_fixtures;
