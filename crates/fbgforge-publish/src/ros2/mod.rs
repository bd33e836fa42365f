//! The ROS 2 messages fbgforge publishes, encoded as ROS 2 puts them on the wire and in
//! bags: plain CDR, little-endian ([`cdr`]), with `ros2msg` schema texts ([`schema`]).
//!
//! The structs mirror the ROS 2 interface definitions field for field (their field names
//! are ROS's); [`Ros2Message`] encodes and decodes them.

pub mod cdr;
pub mod schema;

pub use cdr::{CdrError, CdrReader, CdrWriter};

/// A ROS 2 message type this crate can encode and decode.
pub trait Ros2Message: Sized {
    /// The full type name, `pkg/msg/Type`: the MCAP schema name.
    const TYPE_NAME: &'static str;

    /// Appends the fields in order.
    fn write_cdr(&self, w: &mut CdrWriter);

    /// Reads the fields in order.
    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, CdrError>;

    /// The whole message: encapsulation header and fields.
    fn to_cdr(&self) -> Vec<u8> {
        let mut w = CdrWriter::new();
        self.write_cdr(&mut w);
        w.into_bytes()
    }

    /// Decodes a whole message; fails on trailing bytes.
    fn from_cdr(bytes: &[u8]) -> Result<Self, CdrError> {
        let mut r = CdrReader::new(bytes)?;
        let m = Self::read_cdr(&mut r)?;
        r.finish()?;
        Ok(m)
    }

    /// The `ros2msg` schema text (definition and dependencies).
    fn schema_text() -> String {
        schema::full_text(Self::TYPE_NAME).expect("every Ros2Message type has a definition")
    }
}

/// `builtin_interfaces/msg/Time`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds within the second, below 10⁹.
    pub nanosec: u32,
}

impl Time {
    /// Splits a time in nanoseconds; `None` past `i32::MAX` seconds (January 2038 when
    /// counted from 1970).
    pub fn from_ns(time_ns: u64) -> Option<Time> {
        Some(Time {
            sec: i32::try_from(time_ns / 1_000_000_000).ok()?,
            nanosec: (time_ns % 1_000_000_000) as u32,
        })
    }

    /// Back to nanoseconds (`None` for negative seconds).
    pub fn to_ns(self) -> Option<u64> {
        Some(u64::try_from(self.sec).ok()? * 1_000_000_000 + u64::from(self.nanosec))
    }
}

impl Ros2Message for Time {
    const TYPE_NAME: &'static str = "builtin_interfaces/msg/Time";
    fn write_cdr(&self, w: &mut CdrWriter) {
        w.write_i32(self.sec);
        w.write_u32(self.nanosec);
    }
    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        Ok(Time {
            sec: r.read_i32()?,
            nanosec: r.read_u32()?,
        })
    }
}

/// `std_msgs/msg/Header`.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Header {
    /// When the data was taken.
    pub stamp: Time,
    /// The coordinate frame the data is in.
    pub frame_id: String,
}

impl Ros2Message for Header {
    const TYPE_NAME: &'static str = "std_msgs/msg/Header";
    fn write_cdr(&self, w: &mut CdrWriter) {
        self.stamp.write_cdr(w);
        w.write_string(&self.frame_id);
    }
    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        Ok(Header {
            stamp: Time::read_cdr(r)?,
            frame_id: r.read_string()?,
        })
    }
}

/// `geometry_msgs/msg/Vector3`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

impl Ros2Message for Vector3 {
    const TYPE_NAME: &'static str = "geometry_msgs/msg/Vector3";
    fn write_cdr(&self, w: &mut CdrWriter) {
        w.write_f64(self.x);
        w.write_f64(self.y);
        w.write_f64(self.z);
    }
    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        Ok(Vector3 {
            x: r.read_f64()?,
            y: r.read_f64()?,
            z: r.read_f64()?,
        })
    }
}

/// `geometry_msgs/msg/Point` (same fields as [`Vector3`], another type).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Point {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

impl Ros2Message for Point {
    const TYPE_NAME: &'static str = "geometry_msgs/msg/Point";
    fn write_cdr(&self, w: &mut CdrWriter) {
        w.write_f64(self.x);
        w.write_f64(self.y);
        w.write_f64(self.z);
    }
    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        Ok(Point {
            x: r.read_f64()?,
            y: r.read_f64()?,
            z: r.read_f64()?,
        })
    }
}

/// `geometry_msgs/msg/Wrench`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Wrench {
    /// Force, N.
    pub force: Vector3,
    /// Torque, N·m.
    pub torque: Vector3,
}

impl Ros2Message for Wrench {
    const TYPE_NAME: &'static str = "geometry_msgs/msg/Wrench";
    fn write_cdr(&self, w: &mut CdrWriter) {
        self.force.write_cdr(w);
        self.torque.write_cdr(w);
    }
    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        Ok(Wrench {
            force: Vector3::read_cdr(r)?,
            torque: Vector3::read_cdr(r)?,
        })
    }
}

/// `geometry_msgs/msg/WrenchStamped`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct WrenchStamped {
    /// Stamp and frame.
    pub header: Header,
    /// Force and torque.
    pub wrench: Wrench,
}

impl Ros2Message for WrenchStamped {
    const TYPE_NAME: &'static str = "geometry_msgs/msg/WrenchStamped";
    fn write_cdr(&self, w: &mut CdrWriter) {
        self.header.write_cdr(w);
        self.wrench.write_cdr(w);
    }
    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        Ok(WrenchStamped {
            header: Header::read_cdr(r)?,
            wrench: Wrench::read_cdr(r)?,
        })
    }
}

/// `geometry_msgs/msg/PointStamped`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PointStamped {
    /// Stamp and frame.
    pub header: Header,
    /// The point, m.
    pub point: Point,
}

impl Ros2Message for PointStamped {
    const TYPE_NAME: &'static str = "geometry_msgs/msg/PointStamped";
    fn write_cdr(&self, w: &mut CdrWriter) {
        self.header.write_cdr(w);
        self.point.write_cdr(w);
    }
    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        Ok(PointStamped {
            header: Header::read_cdr(r)?,
            point: Point::read_cdr(r)?,
        })
    }
}

/// `std_msgs/msg/MultiArrayDimension`.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct MultiArrayDimension {
    /// Name of the dimension.
    pub label: String,
    /// Number of elements along it.
    pub size: u32,
    /// Elements spanned by one step of the enclosing dimension (for the outermost, all).
    pub stride: u32,
}

impl Ros2Message for MultiArrayDimension {
    const TYPE_NAME: &'static str = "std_msgs/msg/MultiArrayDimension";
    fn write_cdr(&self, w: &mut CdrWriter) {
        w.write_string(&self.label);
        w.write_u32(self.size);
        w.write_u32(self.stride);
    }
    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        Ok(MultiArrayDimension {
            label: r.read_string()?,
            size: r.read_u32()?,
            stride: r.read_u32()?,
        })
    }
}

/// `std_msgs/msg/MultiArrayLayout`.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct MultiArrayLayout {
    /// The dimensions, outermost first.
    pub dim: Vec<MultiArrayDimension>,
    /// Elements to skip at the start of `data`.
    pub data_offset: u32,
}

impl Ros2Message for MultiArrayLayout {
    const TYPE_NAME: &'static str = "std_msgs/msg/MultiArrayLayout";
    fn write_cdr(&self, w: &mut CdrWriter) {
        w.write_sequence_len(self.dim.len());
        for d in &self.dim {
            d.write_cdr(w);
        }
        w.write_u32(self.data_offset);
    }
    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        // A dimension takes at least 13 bytes: length 4, NUL 1, size 4, stride 4.
        let n = r.read_sequence_len(13)?;
        let dim = (0..n)
            .map(|_| MultiArrayDimension::read_cdr(r))
            .collect::<Result<_, _>>()?;
        Ok(MultiArrayLayout {
            dim,
            data_offset: r.read_u32()?,
        })
    }
}

/// `std_msgs/msg/Float64MultiArray`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Float64MultiArray {
    /// How `data` is laid out.
    pub layout: MultiArrayLayout,
    /// The values.
    pub data: Vec<f64>,
}

impl Float64MultiArray {
    /// One dimension named `label` over all of `data` (size = stride = its length).
    ///
    /// # Panics
    /// When `data` has 2³² or more values.
    pub fn labelled_1d(label: &str, data: Vec<f64>) -> Self {
        let n = u32::try_from(data.len()).expect("fewer than 2^32 values");
        Float64MultiArray {
            layout: MultiArrayLayout {
                dim: vec![MultiArrayDimension {
                    label: label.to_owned(),
                    size: n,
                    stride: n,
                }],
                data_offset: 0,
            },
            data,
        }
    }
}

impl Ros2Message for Float64MultiArray {
    const TYPE_NAME: &'static str = "std_msgs/msg/Float64MultiArray";
    fn write_cdr(&self, w: &mut CdrWriter) {
        self.layout.write_cdr(w);
        w.write_f64_sequence(&self.data);
    }
    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        Ok(Float64MultiArray {
            layout: MultiArrayLayout::read_cdr(r)?,
            data: r.read_f64_sequence()?,
        })
    }
}

/// `std_msgs/msg/String`.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct StringMessage {
    /// The text.
    pub data: String,
}

impl Ros2Message for StringMessage {
    const TYPE_NAME: &'static str = "std_msgs/msg/String";
    fn write_cdr(&self, w: &mut CdrWriter) {
        w.write_string(&self.data);
    }
    fn read_cdr(r: &mut CdrReader<'_>) -> Result<Self, CdrError> {
        Ok(StringMessage {
            data: r.read_string()?,
        })
    }
}

#[cfg(test)]
mod tests;
