//! The NRRD header parser and writer against hand-written headers and round trips.

use super::*;
use proptest::prelude::*;

const GOOD: &str = "NRRD0004\n\
    # comment\n\
    type: float\n\
    dimension: 3\n\
    space dimension: 3\n\
    sizes: 13 9 5\n\
    space directions: (0.5,0,0) (0, 1.0, 0) (0,0,2.0)\n\
    kinds: domain domain domain\n\
    endian: little\n\
    encoding: raw\n\
    space origin: (1000000.0,-3.0,0.25)\n\
    volga_background:=-1.5\n\
    data file: v.raw\n";

#[test]
fn parses_a_detached_header() {
    let h = parse_header_text(GOOD).unwrap();
    assert_eq!(h.dimension, 3);
    assert_eq!(h.scalar, Some(ScalarType::F32));
    assert_eq!(h.sizes, vec![13, 9, 5]);
    assert_eq!(h.endian, Some(Endian::Little));
    assert_eq!(h.space_dimension, Some(3));
    assert_eq!(
        h.space_directions,
        Some(vec![
            Some(vec![0.5, 0.0, 0.0]),
            Some(vec![0.0, 1.0, 0.0]),
            Some(vec![0.0, 0.0, 2.0])
        ])
    );
    assert_eq!(h.space_origin, Some(vec![1e6, -3.0, 0.25]));
    assert_eq!(h.data_file.as_deref(), Some("v.raw"));
    assert_eq!(h.key_value(BACKGROUND_KEY), Some("-1.5"));
    assert_eq!(h.line_of("sizes"), Some(6));
    assert_eq!(h.sample_count(), Some(13 * 9 * 5));
}

fn error_of(text: &str) -> HeaderError {
    parse_header_text(text).unwrap_err()
}

#[test]
fn errors_name_the_line() {
    let e = error_of(&GOOD.replace("kinds:", "foo:"));
    assert_eq!(e.line, Some(8));
    assert_eq!(e.message, "unknown field `foo`");

    let e = error_of(&GOOD.replace("sizes: 13 9 5\n", ""));
    assert!(e.message.contains("`sizes`"), "{e:?}");
    assert!(e.line.is_some());

    let e = error_of(&GOOD.replace("encoding: raw", "encoding: gzip"));
    assert_eq!(e.line, Some(10));
    assert!(e.message.starts_with("unsupported encoding gzip"), "{e:?}");
    let e = error_of(&GOOD.replace("encoding: raw", "encoding: zip"));
    assert_eq!(e.message, "unknown encoding zip");

    let e = error_of(&GOOD.replace("sizes: 13 9 5", "sizes: 13 9"));
    assert_eq!(e.line, Some(6));
    let e = error_of(&GOOD.replace("sizes: 13 9 5", "sizes: 13 0 5"));
    assert_eq!(e.line, Some(6));
    let e = error_of(&GOOD.replace("(0,0,2.0)", "(0,0,2.0"));
    assert_eq!(e.line, Some(7));
    let e = error_of(&GOOD.replace("type: float", "type: block"));
    assert!(e.message.contains("unsupported type"), "{e:?}");
    let e = error_of(&GOOD.replace("endian: little", "endian: middle"));
    assert_eq!(e.line, Some(9));
    let e = error_of(&GOOD.replace("# comment", "dimension: 3"));
    assert_eq!(e.line, Some(4));
    assert!(e.message.contains("twice"));
    let e = error_of(&GOOD.replace("NRRD0004", "NRRD0009"));
    assert_eq!(e.line, Some(1));
    let e = error_of("");
    assert_eq!(e.line, Some(1));
    let e = error_of(&GOOD.replace("data file: v.raw", "data file: v%03d.raw 1 5 1"));
    assert!(e.message.contains("multi-file"));
}

#[test]
fn header_ends_at_blank_line_and_accepts_aliases() {
    let text = "NRRD0005\nTYPE: unsigned short\ndimension: 3\nSizes: 2 2 2\n\
                spacings: 0.5 NaN 2\ncenterings: cell node ???\nencoding: raw\nendian: big\n\
                \nfoo: junk after the header\n";
    let h = parse_header_text(text).unwrap();
    assert_eq!(h.scalar, Some(ScalarType::U16));
    assert_eq!(h.endian, Some(Endian::Big));
    let s = h.spacings.unwrap();
    assert_eq!(s[0], 0.5);
    assert!(s[1].is_nan());
    assert_eq!(h.centers, Some(vec![Center::Cell, Center::Node, Center::Unknown]));
}

#[test]
fn formats_round_trip() {
    for x in [0.0, -0.0, 0.5, 1e6, -3.0, 1e-300, 1e300, 0.1 + 0.2, 123456.789] {
        let s = fmt_f64(x);
        let y: f64 = s.parse().unwrap();
        assert_eq!(x.to_bits(), y.to_bits(), "{s}");
    }
    assert_eq!(fmt_vector(&[0.5, 0.0, 0.0]), "(0.5,0,0)");
    assert_eq!(fmt_vector(&[1e6, -3.0, 0.25]), "(1000000.0,-3.0,0.25)");
}

#[test]
fn decodes_all_types() {
    let mut out = [0.0f32; 5];
    ScalarType::I16.decode_le(&(-2i16).to_le_bytes(), &mut out[0..1]);
    ScalarType::U8.decode_le(&[200], &mut out[1..2]);
    ScalarType::F64.decode_le(&0.25f64.to_le_bytes(), &mut out[2..3]);
    ScalarType::U32.decode_le(&7u32.to_le_bytes(), &mut out[3..4]);
    ScalarType::I8.decode_le(&[0xff], &mut out[4..5]);
    assert_eq!(out, [-2.0, 200.0, 0.25, 7.0, -1.0]);
}

fn field_line() -> impl Strategy<Value = String> {
    let names = prop::sample::select(vec![
        "type",
        "dimension",
        "sizes",
        "encoding",
        "endian",
        "space",
        "space dimension",
        "space directions",
        "space origin",
        "spacings",
        "axis mins",
        "centers",
        "kinds",
        "data file",
        "line skip",
        "byte skip",
        "content",
        "bogus",
    ]);
    let values = prop_oneof![
        "[ -~]{0,24}",
        prop::sample::select(vec![
            "float",
            "3",
            "2 3 4",
            "raw",
            "gzip",
            "little",
            "big",
            "RAS",
            "(1,0,0) none (0,0,1)",
            "(1,0,0) (0,1,0) (0,0,1)",
            "(0,0,0)",
            "1 1 1",
            "cell node cell",
            "x.raw",
            "-1",
            "18446744073709551615 18446744073709551615 2",
            "(",
            "none",
            "(,)",
            "nan",
        ])
        .prop_map(str::to_string),
    ];
    prop_oneof![
        (names, values).prop_map(|(n, v)| format!("{n}: {v}")),
        "[ -~]{0,40}",
        "[a-z]{1,8}:=[ -~]{0,10}",
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..200)) {
        let text = String::from_utf8_lossy(&bytes);
        let _ = parse_header_text(&text);
        let _ = parse_header_text(&format!("NRRD0004\n{text}"));
    }

    #[test]
    fn random_field_lines_never_panic(lines in prop::collection::vec(field_line(), 0..14)) {
        let text = format!("NRRD0004\n{}\n", lines.join("\n"));
        match parse_header_text(&text) {
            Ok(h) => prop_assert_eq!(h.sizes.len(), h.dimension),
            Err(e) => prop_assert!(e.line.is_some()),
        }
    }
}
