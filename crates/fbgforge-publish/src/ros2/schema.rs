//! `ros2msg` schema texts: a message's definition with every dependency appended, in
//! the form rosbag2 writes into MCAP files.
//!
//! rosbag2's local definition source builds the text recursively: the type's `.msg`
//! text, then for each dependency it has not yet written — a type's dependencies taken
//! in sorted order (`std::set`) and depth-first — a newline, a line of 80 `=`, a line
//! `MSG: pkg/Type` (no `msg/` in the name), and that dependency's text with its own
//! dependencies after it. The definitions below are the fields of the ROS 2
//! interfaces (`common_interfaces`, `rcl_interfaces`), without their comments.

use std::collections::BTreeSet;

/// The `.msg` text of each type this crate writes, and its direct dependencies.
const DEFINITIONS: &[(&str, &str, &[&str])] = &[
    (
        "builtin_interfaces/Time",
        "int32 sec\nuint32 nanosec\n",
        &[],
    ),
    (
        "std_msgs/Header",
        "builtin_interfaces/Time stamp\nstring frame_id\n",
        &["builtin_interfaces/Time"],
    ),
    (
        "geometry_msgs/Vector3",
        "float64 x\nfloat64 y\nfloat64 z\n",
        &[],
    ),
    (
        "geometry_msgs/Wrench",
        "Vector3 force\nVector3 torque\n",
        &["geometry_msgs/Vector3"],
    ),
    (
        "geometry_msgs/WrenchStamped",
        "std_msgs/Header header\nWrench wrench\n",
        &["geometry_msgs/Wrench", "std_msgs/Header"],
    ),
    (
        "geometry_msgs/Point",
        "float64 x\nfloat64 y\nfloat64 z\n",
        &[],
    ),
    (
        "geometry_msgs/PointStamped",
        "std_msgs/Header header\nPoint point\n",
        &["geometry_msgs/Point", "std_msgs/Header"],
    ),
    (
        "std_msgs/MultiArrayDimension",
        "string label\nuint32 size\nuint32 stride\n",
        &[],
    ),
    (
        "std_msgs/MultiArrayLayout",
        "MultiArrayDimension[] dim\nuint32 data_offset\n",
        &["std_msgs/MultiArrayDimension"],
    ),
    (
        "std_msgs/Float64MultiArray",
        "MultiArrayLayout layout\nfloat64[] data\n",
        &["std_msgs/MultiArrayLayout"],
    ),
    ("std_msgs/String", "string data\n", &[]),
];

/// The delimiter rosbag2 writes before a dependency's definition.
pub const DELIMITER: &str =
    "================================================================================";

/// `pkg/msg/Type` or `pkg/Type` → `pkg/Type` (rosbag2's dependency names drop the
/// `msg/`).
fn short_name(type_name: &str) -> Option<String> {
    match type_name.split('/').collect::<Vec<_>>().as_slice() {
        [pkg, "msg", name] | [pkg, name] => Some(format!("{pkg}/{name}")),
        _ => None,
    }
}

fn lookup(short: &str) -> Option<(&'static str, &'static [&'static str])> {
    DEFINITIONS
        .iter()
        .find(|(name, _, _)| *name == short)
        .map(|&(_, text, deps)| (text, deps))
}

fn append(short: &str, seen: &mut BTreeSet<String>, out: &mut String) {
    let (text, deps) = lookup(short).expect("every dependency is defined");
    out.push_str(text);
    let sorted: BTreeSet<&str> = deps.iter().copied().collect();
    for dep in sorted {
        if seen.insert(dep.to_owned()) {
            out.push('\n');
            out.push_str(DELIMITER);
            out.push_str("\nMSG: ");
            out.push_str(dep);
            out.push('\n');
            append(dep, seen, out);
        }
    }
}

/// The full `ros2msg` text of `type_name` (`pkg/msg/Type` or `pkg/Type`), or `None` for
/// a type this crate does not define.
pub fn full_text(type_name: &str) -> Option<String> {
    let short = short_name(type_name)?;
    lookup(&short)?;
    let mut out = String::new();
    append(&short, &mut BTreeSet::new(), &mut out);
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn eq80() -> String {
        "=".repeat(80)
    }

    #[test]
    fn wrench_stamped_is_written_as_rosbag2_writes_it() {
        // Dependencies sorted: geometry_msgs/Wrench (then its Vector3) before
        // std_msgs/Header (then its builtin_interfaces/Time); each after a blank line
        // (the definition's own final newline, then rosbag2's "\n").
        let want = format!(
            "std_msgs/Header header\nWrench wrench\n\n{d}\nMSG: geometry_msgs/Wrench\n\
             Vector3 force\nVector3 torque\n\n{d}\nMSG: geometry_msgs/Vector3\n\
             float64 x\nfloat64 y\nfloat64 z\n\n{d}\nMSG: std_msgs/Header\n\
             builtin_interfaces/Time stamp\nstring frame_id\n\n{d}\nMSG: builtin_interfaces/Time\n\
             int32 sec\nuint32 nanosec\n",
            d = eq80()
        );
        assert_eq!(full_text("geometry_msgs/msg/WrenchStamped").unwrap(), want);
        assert_eq!(DELIMITER, eq80());
    }

    #[test]
    fn each_dependency_is_written_once() {
        let text = full_text("geometry_msgs/msg/PointStamped").unwrap();
        assert_eq!(text.matches("MSG: ").count(), 3, "{text}");
        assert!(
            text.find("MSG: geometry_msgs/Point").unwrap()
                < text.find("MSG: std_msgs/Header").unwrap()
        );
        let text = full_text("std_msgs/msg/Float64MultiArray").unwrap();
        assert_eq!(
            text,
            format!(
                "MultiArrayLayout layout\nfloat64[] data\n\n{d}\nMSG: std_msgs/MultiArrayLayout\n\
                 MultiArrayDimension[] dim\nuint32 data_offset\n\n{d}\nMSG: std_msgs/MultiArrayDimension\n\
                 string label\nuint32 size\nuint32 stride\n",
                d = eq80()
            )
        );
        assert_eq!(full_text("std_msgs/msg/String").unwrap(), "string data\n");
        assert_eq!(full_text("std_msgs/msg/Bool"), None);
    }
}
