//! Byte-exact encodings worked out by hand from the CDR rules in `cdr.rs`. Offsets in
//! the comments count from the end of the 4-byte encapsulation header (the alignment
//! origin); the `f64` bytes are IEEE 754 little-endian (5.0 = 0x4014000000000000,
//! 1550.0 = 0x4098380000000000, 1.5 = 0x3FF8000000000000, -2.0 = 0xC000000000000000).

use super::*;

const HDR: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

fn with_header(payload: &[u8]) -> Vec<u8> {
    let mut v = HDR.to_vec();
    v.extend_from_slice(payload);
    v
}

fn roundtrip<M: Ros2Message + PartialEq + std::fmt::Debug>(m: &M, want: &[u8]) {
    let bytes = m.to_cdr();
    assert_eq!(bytes, want, "{m:?}");
    assert_eq!(&M::from_cdr(&bytes).unwrap(), m);
}

#[test]
fn time() {
    // 0: sec 1_700_000_000 = 0x6553F100 → 00 F1 53 65
    // 4: nanosec 5 → 05 00 00 00                                    (8 bytes)
    let t = Time::from_ns(1_700_000_000_000_000_005).unwrap();
    assert_eq!(
        t,
        Time {
            sec: 1_700_000_000,
            nanosec: 5
        }
    );
    roundtrip(&t, &with_header(&[0x00, 0xF1, 0x53, 0x65, 0x05, 0, 0, 0]));
    assert_eq!(t.to_ns(), Some(1_700_000_000_000_000_005));
    assert_eq!(
        Time::from_ns(u64::MAX),
        None,
        "past 2038 does not fit int32"
    );
}

#[test]
fn wrench_stamped_pads_after_the_frame_id_to_eight() {
    // 0:  sec 2                                   02 00 00 00
    // 4:  nanosec 500_000_000 = 0x1DCD6500        00 65 CD 1D
    // 8:  frame_id length 2 ("f" + NUL)           02 00 00 00
    // 12: 'f' NUL                                 66 00
    // 14: pad to 16 (force.x is a float64)        00 00
    // 16: force.x 0, 24: force.y 0, 32: force.z 5.0, 40..64: torque 0 0 0  (64 bytes)
    let m = WrenchStamped {
        header: Header {
            stamp: Time {
                sec: 2,
                nanosec: 500_000_000,
            },
            frame_id: "f".into(),
        },
        wrench: Wrench {
            force: Vector3 {
                x: 0.0,
                y: 0.0,
                z: 5.0,
            },
            torque: Vector3::default(),
        },
    };
    let mut p = vec![
        2, 0, 0, 0, 0x00, 0x65, 0xCD, 0x1D, 2, 0, 0, 0, b'f', 0, 0, 0,
    ];
    p.extend_from_slice(&[0; 16]); // force.x, force.y
    p.extend_from_slice(&[0, 0, 0, 0, 0, 0, 0x14, 0x40]); // force.z = 5.0
    p.extend_from_slice(&[0; 24]); // torque
    assert_eq!(p.len(), 64);
    roundtrip(&m, &with_header(&p));
}

#[test]
fn point_stamped_with_an_empty_frame_id() {
    // 0:  sec 0, 4: nanosec 0                     00×8
    // 8:  frame_id "" → length 1 (the NUL)        01 00 00 00
    // 12: NUL                                     00
    // 13: pad to 16                               00 00 00
    // 16: x 1.5, 24: y -2.0, 32: z 0              (40 bytes)
    let m = PointStamped {
        header: Header::default(),
        point: Point {
            x: 1.5,
            y: -2.0,
            z: 0.0,
        },
    };
    let mut p = vec![0; 8];
    p.extend_from_slice(&[1, 0, 0, 0, 0, 0, 0, 0]);
    p.extend_from_slice(&[0, 0, 0, 0, 0, 0, 0xF8, 0x3F]);
    p.extend_from_slice(&[0, 0, 0, 0, 0, 0, 0, 0xC0]);
    p.extend_from_slice(&[0; 8]);
    assert_eq!(p.len(), 40);
    roundtrip(&m, &with_header(&p));
}

#[test]
fn float64_multi_array_pads_after_the_label_and_before_the_data() {
    // 0:  dim count 1                             01 00 00 00
    // 4:  label length 9 ("gratings" + NUL)       09 00 00 00
    // 8:  "gratings" NUL                          67 72 61 74 69 6E 67 73 00   (to 17)
    // 17: pad to 20 (size is a uint32)            00 00 00
    // 20: size 1, 24: stride 1, 28: data_offset 0
    // 32: data count 1                            01 00 00 00
    // 36: pad to 40 (the value is a float64)      00 00 00 00
    // 40: 1550.0                                  00 00 00 00 00 38 98 40     (48 bytes)
    let m = Float64MultiArray::labelled_1d("gratings", vec![1550.0]);
    let mut p = vec![1, 0, 0, 0, 9, 0, 0, 0];
    p.extend_from_slice(b"gratings\0");
    p.extend_from_slice(&[0, 0, 0]);
    p.extend_from_slice(&[1, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0]);
    p.extend_from_slice(&[1, 0, 0, 0, 0, 0, 0, 0]);
    p.extend_from_slice(&[0, 0, 0, 0, 0, 0x38, 0x98, 0x40]);
    assert_eq!(p.len(), 48);
    roundtrip(&m, &with_header(&p));
}

#[test]
fn float64_multi_array_with_no_padding_needed_and_an_empty_one() {
    // 0: count 1; 4: length 6; 8: "cells" NUL (to 14); 14: pad 2; 16: size 2;
    // 20: stride 2; 24: data_offset 0; 28: count 2; 32: 1.5; 40: -2.0   (48 bytes)
    let m = Float64MultiArray::labelled_1d("cells", vec![1.5, -2.0]);
    let mut p = vec![1, 0, 0, 0, 6, 0, 0, 0];
    p.extend_from_slice(b"cells\0\0\0");
    p.extend_from_slice(&[2, 0, 0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 2, 0, 0, 0]);
    p.extend_from_slice(&[0, 0, 0, 0, 0, 0, 0xF8, 0x3F]);
    p.extend_from_slice(&[0, 0, 0, 0, 0, 0, 0, 0xC0]);
    roundtrip(&m, &with_header(&p));

    // No dimension, no data: count 0, data_offset 0, count 0; an empty float64
    // sequence adds no alignment after its count (12 bytes).
    let empty = Float64MultiArray::default();
    roundtrip(&empty, &with_header(&[0; 12]));
}

#[test]
fn strings() {
    // "" → length 1, NUL; "ok" → length 3, 'o' 'k' NUL. No padding at the end.
    roundtrip(&StringMessage::default(), &with_header(&[1, 0, 0, 0, 0]));
    roundtrip(
        &StringMessage { data: "ok".into() },
        &with_header(&[3, 0, 0, 0, b'o', b'k', 0]),
    );
    // UTF-8 bytes are counted, not characters: "µ" is 2 bytes, length 3.
    roundtrip(
        &StringMessage { data: "µ".into() },
        &with_header(&[3, 0, 0, 0, 0xC2, 0xB5, 0]),
    );
}

#[test]
fn malformed_bytes_are_errors() {
    assert_eq!(
        StringMessage::from_cdr(&[0, 0, 0, 0, 1, 0, 0, 0, 0]),
        Err(CdrError::Encapsulation([0, 0, 0, 0]))
    );
    assert_eq!(
        StringMessage::from_cdr(&with_header(&[3, 0, 0, 0, b'o', b'k', b'!'])),
        Err(CdrError::BadString { offset: 4 })
    );
    assert_eq!(
        StringMessage::from_cdr(&with_header(&[9, 0, 0, 0, b'o'])),
        Err(CdrError::Truncated { offset: 8 })
    );
    assert_eq!(
        StringMessage::from_cdr(&with_header(&[1, 0, 0, 0, 0, 7])),
        Err(CdrError::TrailingBytes { count: 1 })
    );
    // A count of 2^32 - 1 dimensions in a short message is caught before allocating.
    assert!(
        MultiArrayLayout::from_cdr(&with_header(&[0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0, 0])).is_err()
    );
    // An empty string written as length 0 (some serializers) still reads.
    assert_eq!(
        StringMessage::from_cdr(&with_header(&[0, 0, 0, 0]))
            .unwrap()
            .data,
        ""
    );
}

#[test]
fn type_names_and_schemas() {
    assert_eq!(WrenchStamped::TYPE_NAME, "geometry_msgs/msg/WrenchStamped");
    assert_eq!(PointStamped::TYPE_NAME, "geometry_msgs/msg/PointStamped");
    assert_eq!(
        Float64MultiArray::TYPE_NAME,
        "std_msgs/msg/Float64MultiArray"
    );
    assert_eq!(StringMessage::TYPE_NAME, "std_msgs/msg/String");
    assert!(WrenchStamped::schema_text().starts_with("std_msgs/Header header\nWrench wrench\n"));
    assert!(Header::schema_text()
        .ends_with("MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n"));
    assert_eq!(Time::schema_text(), "int32 sec\nuint32 nanosec\n");
    assert_eq!(Wrench::schema_text().matches("MSG: ").count(), 1);
    assert_eq!(Vector3::schema_text(), Point::schema_text());
    assert!(MultiArrayDimension::schema_text().starts_with("string label"));
}
