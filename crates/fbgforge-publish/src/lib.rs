//! Publishing fbgforge live readings for robots and people.
//!
//! * [`ros2`]: ROS 2 messages (`geometry_msgs/WrenchStamped`, `PointStamped`,
//!   `std_msgs/Float64MultiArray`, `String`) encoded in plain CDR, with their `ros2msg`
//!   schema texts;
//! * [`mcap`]: [`McapRecorder`], which writes a live run as an MCAP file of those
//!   messages, readable by Foxglove, `ros2 bag` (MCAP storage) and the Python `mcap`
//!   packages;
//! * [`web`]: [`serve`], a browser view (one self-contained page and a Server-Sent
//!   Events stream) on a plain `std::net::TcpListener`.
//!
//! The crate takes plain data (frame time in ns, forces and loads in N, positions in m,
//! peaks in nm, flags as words, the tare state): it does not depend on `fbgforge`.

mod data;
pub mod mcap;
pub mod ros2;
pub mod web;

pub use crate::data::{
    core_frame_id, ros_name_token, wrench_topic, PublishError, TareState, DIM_CELLS, DIM_GRATINGS,
    FRAME_ID_ARRAY, TOPIC_CELLS, TOPIC_CONTACT, TOPIC_FLAGS, TOPIC_PEAKS, TOPIC_PREFIX, TOPIC_TARE,
};
pub use crate::mcap::{
    ArrayReading, McapRecorder, ModuleReading, RecorderSetup, RecordingSummary, SensorLayout,
};
pub use crate::web::{serve, WebView};
