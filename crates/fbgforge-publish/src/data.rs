//! Plain data shared by the recorder and the browser view: the tare state, the errors,
//! and the names of topics and frames.

use std::fmt;
use std::path::PathBuf;

/// Where the zero-load reference stands.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum TareState {
    /// Tared on a window in which every grating was at rest: loads are shown.
    Resting,
    /// Waiting for the gratings to come to rest before taring: no loads yet.
    Waiting,
    /// Gave up waiting: these gratings kept moving; no loads are shown.
    Refused {
        /// The gratings whose spread or trend exceeded the resolution.
        moving_gratings: Vec<String>,
    },
    /// No tare (`--no-tare`): shifts are taken from the nominal wavelengths.
    Nominal,
}

impl TareState {
    /// One word: `resting`, `waiting`, `refused` or `nominal`.
    pub fn word(&self) -> &'static str {
        match self {
            TareState::Resting => "resting",
            TareState::Waiting => "waiting",
            TareState::Refused { .. } => "refused",
            TareState::Nominal => "nominal",
        }
    }
}

/// `resting`, `waiting`, `nominal`, or `refused: moving gratings A, B`.
impl fmt::Display for TareState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TareState::Refused { moving_gratings } => {
                write!(f, "refused: moving gratings {}", moving_gratings.join(", "))
            }
            other => f.write_str(other.word()),
        }
    }
}

/// What went wrong while publishing.
#[derive(Debug, thiserror::Error)]
pub enum PublishError {
    /// Reading or writing a file.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The system's error.
        source: std::io::Error,
    },
    /// The MCAP writer's error.
    #[error("MCAP: {0}")]
    Mcap(#[from] ::mcap::McapError),
    /// `builtin_interfaces/Time` holds int32 seconds: up to January 2038 from 1970.
    #[error("frame time {frame_time_ns} ns is past int32 seconds (builtin_interfaces/Time)")]
    FrameTimeOutOfRange {
        /// The time given.
        frame_time_ns: u64,
    },
    /// A reading's values do not match the labels it was set up with.
    #[error("{what}: {got} values for {expected} labels")]
    LengthMismatch {
        /// Which values.
        what: &'static str,
        /// How many labels.
        expected: usize,
        /// How many values.
        got: usize,
    },
    /// A module reading given to an array recorder, or the reverse.
    #[error("a {setup} recorder cannot record a {given} reading")]
    WrongKind {
        /// What the recorder was set up for.
        setup: &'static str,
        /// What it was given.
        given: &'static str,
    },
    /// Labels that are empty, repeated, or that give two cores one topic name.
    #[error("bad labels: {0}")]
    Labels(String),
    /// The recorder already failed once; the file is left as `.partial`.
    #[error("the recorder failed earlier and records nothing more")]
    Poisoned,
}

/// Prefix of every topic.
pub const TOPIC_PREFIX: &str = "/fbgforge";
/// Per-cell loads of an array (N), `std_msgs/msg/Float64MultiArray`.
pub const TOPIC_CELLS: &str = "/fbgforge/cells";
/// Load-weighted contact centroid of an array (m), `geometry_msgs/msg/PointStamped`.
pub const TOPIC_CONTACT: &str = "/fbgforge/contact";
/// Peak wavelengths (nm), `std_msgs/msg/Float64MultiArray`.
pub const TOPIC_PEAKS: &str = "/fbgforge/peaks";
/// The frame's trust flags, `std_msgs/msg/String`.
pub const TOPIC_FLAGS: &str = "/fbgforge/flags";
/// The tare state, `std_msgs/msg/String`, on the first frame and on each change.
pub const TOPIC_TARE: &str = "/fbgforge/tare";
/// `header.frame_id` of an array's messages.
pub const FRAME_ID_ARRAY: &str = "fbgforge_array";
/// Dimension label of `/fbgforge/cells`.
pub const DIM_CELLS: &str = "cells";
/// Dimension label of `/fbgforge/peaks`.
pub const DIM_GRATINGS: &str = "gratings";

/// A label as one ROS 2 name token: letters, digits and single underscores, not
/// starting with a digit. Other characters become `_`, runs of `_` one `_`, a leading
/// or trailing `_` is dropped, and a token that would start with a digit (or be
/// empty) gets the prefix `core_`.
pub fn ros_name_token(label: &str) -> String {
    let mut out = String::with_capacity(label.len());
    for c in label.chars() {
        let c = if c.is_ascii_alphanumeric() { c } else { '_' };
        if !(c == '_' && (out.is_empty() || out.ends_with('_'))) {
            out.push(c);
        }
    }
    while out.ends_with('_') {
        out.pop();
    }
    if out.is_empty() || out.starts_with(|c: char| c.is_ascii_digit()) {
        out.insert_str(0, "core_");
        if out.ends_with('_') {
            out.pop();
        }
    }
    out
}

/// `/fbgforge/<core>/wrench`, `<core>` made a ROS name token ([`ros_name_token`]).
pub fn wrench_topic(core_label: &str) -> String {
    format!("{TOPIC_PREFIX}/{}/wrench", ros_name_token(core_label))
}

/// `fbgforge_<core>`: the `header.frame_id` of a core's wrench. Its z axis is the
/// module's axis, along which the core carries the force.
pub fn core_frame_id(core_label: &str) -> String {
    format!("fbgforge_{}", ros_name_token(core_label))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_become_ros_names() {
        assert_eq!(ros_name_token("psc1"), "psc1");
        assert_eq!(ros_name_token("PSC 1"), "PSC_1");
        assert_eq!(ros_name_token("λ-21 (strain)"), "core_21_strain");
        assert_eq!(ros_name_token("1"), "core_1");
        assert_eq!(ros_name_token("__"), "core");
        assert_eq!(ros_name_token(""), "core");
        assert_eq!(wrench_topic("psc1"), "/fbgforge/psc1/wrench");
        assert_eq!(core_frame_id("PSC 2"), "fbgforge_PSC_2");
    }

    #[test]
    fn tare_state_text() {
        assert_eq!(TareState::Resting.to_string(), "resting");
        assert_eq!(TareState::Waiting.to_string(), "waiting");
        let refused = TareState::Refused {
            moving_gratings: vec!["lambda_1".into(), "lambda_4".into()],
        };
        assert_eq!(
            refused.to_string(),
            "refused: moving gratings lambda_1, lambda_4"
        );
        assert_eq!(refused.word(), "refused");
    }
}
