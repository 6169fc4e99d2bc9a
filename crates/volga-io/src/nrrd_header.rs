//! NRRD text header: a line-by-line parser (no I/O, never panics) and the
//! formatting helpers the writer shares with it.
//!
//! Reference: the NRRD format definition (teem), versions NRRD0001–NRRD0005.

use std::collections::HashMap;

/// Magic line this crate writes (`space dimension` needs NRRD0004).
pub(crate) const MAGIC: &str = "NRRD0004";

/// Key of the `key:=value` pair in which volga records the density background.
pub(crate) const BACKGROUND_KEY: &str = "volga_background";

/// A header error: 1-based line (None when it concerns no single line) and message.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct HeaderError {
    pub line: Option<usize>,
    pub message: String,
}

fn err<T>(line: usize, message: impl Into<String>) -> Result<T, HeaderError> {
    Err(HeaderError {
        line: Some(line),
        message: message.into(),
    })
}

/// Sample types a NRRD may store; all are converted to `f32` on reading.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ScalarType {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl ScalarType {
    fn parse(s: &str) -> Option<ScalarType> {
        use ScalarType::*;
        Some(match s {
            "signed char" | "int8" | "int8_t" => I8,
            "uchar" | "unsigned char" | "uint8" | "uint8_t" => U8,
            "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => I16,
            "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => U16,
            "int" | "signed int" | "int32" | "int32_t" => I32,
            "uint" | "unsigned int" | "uint32" | "uint32_t" => U32,
            "float" => F32,
            "double" => F64,
            _ => return None,
        })
    }

    /// Bytes per sample.
    pub fn size(self) -> usize {
        use ScalarType::*;
        match self {
            I8 | U8 => 1,
            I16 | U16 => 2,
            I32 | U32 | F32 => 4,
            F64 => 8,
        }
    }

    /// The NRRD spelling.
    pub fn name(self) -> &'static str {
        use ScalarType::*;
        match self {
            I8 => "int8",
            U8 => "uchar",
            I16 => "short",
            U16 => "ushort",
            I32 => "int",
            U32 => "uint",
            F32 => "float",
            F64 => "double",
        }
    }

    /// Decodes little-endian samples into `out` (`bytes.len() == out.len() · size`).
    pub fn decode_le(self, bytes: &[u8], out: &mut [f32]) {
        use ScalarType::*;
        fn each<const N: usize>(bytes: &[u8], out: &mut [f32], f: impl Fn([u8; N]) -> f32) {
            debug_assert_eq!(bytes.len(), out.len() * N);
            for (o, c) in out.iter_mut().zip(bytes.chunks_exact(N)) {
                *o = f(c.try_into().expect("chunks_exact yields N bytes"));
            }
        }
        match self {
            I8 => each::<1>(bytes, out, |b| i8::from_le_bytes(b) as f32),
            U8 => each::<1>(bytes, out, |b| b[0] as f32),
            I16 => each::<2>(bytes, out, |b| i16::from_le_bytes(b) as f32),
            U16 => each::<2>(bytes, out, |b| u16::from_le_bytes(b) as f32),
            I32 => each::<4>(bytes, out, |b| i32::from_le_bytes(b) as f32),
            U32 => each::<4>(bytes, out, |b| u32::from_le_bytes(b) as f32),
            F32 => each::<4>(bytes, out, f32::from_le_bytes),
            F64 => each::<8>(bytes, out, |b| f64::from_le_bytes(b) as f32),
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Endian {
    Little,
    Big,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Center {
    Cell,
    Node,
    Unknown,
}

/// A parsed header. Per-axis lists have `dimension` entries (checked by `finish`).
#[derive(Debug, Clone, PartialEq, Default)]
pub(crate) struct NrrdHeader {
    pub dimension: usize,
    pub scalar: Option<ScalarType>,
    pub sizes: Vec<u64>,
    pub endian: Option<Endian>,
    pub space_dimension: Option<usize>,
    /// One entry per axis: `None` for `none`.
    pub space_directions: Option<Vec<Option<Vec<f64>>>>,
    pub space_origin: Option<Vec<f64>>,
    pub spacings: Option<Vec<f64>>,
    pub axis_mins: Option<Vec<f64>>,
    pub centers: Option<Vec<Center>>,
    pub kinds: Option<Vec<String>>,
    pub data_file: Option<String>,
    pub line_skip: u64,
    /// `-1`: the data are the last bytes of the data file.
    pub byte_skip: i64,
    pub key_values: Vec<(String, String)>,
    /// Line of each field present (canonical name → line), for later errors.
    pub lines: HashMap<&'static str, usize>,
}

impl NrrdHeader {
    /// Line of `field`, if present.
    pub fn line_of(&self, field: &str) -> Option<usize> {
        self.lines.get(field).copied()
    }

    pub fn key_value(&self, key: &str) -> Option<&str> {
        self.key_values.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
    }

    /// Number of samples, if it fits in `u64`.
    pub fn sample_count(&self) -> Option<u64> {
        self.sizes.iter().try_fold(1u64, |acc, &s| acc.checked_mul(s))
    }
}

/// Canonical field names (lower case, one space between words) and the spellings
/// accepted for them (compared after lower-casing and removing spaces).
const FIELDS: &[(&str, &[&str])] = &[
    ("content", &["content"]),
    ("number", &["number"]),
    ("type", &["type"]),
    ("block size", &["blocksize"]),
    ("dimension", &["dimension"]),
    ("space", &["space"]),
    ("space dimension", &["spacedimension"]),
    ("sizes", &["sizes"]),
    ("spacings", &["spacings"]),
    ("thicknesses", &["thicknesses"]),
    ("axis mins", &["axismins"]),
    ("axis maxs", &["axismaxs"]),
    ("space directions", &["spacedirections"]),
    ("centers", &["centers", "centerings"]),
    ("kinds", &["kinds"]),
    ("labels", &["labels"]),
    ("units", &["units"]),
    ("min", &["min"]),
    ("max", &["max"]),
    ("old min", &["oldmin"]),
    ("old max", &["oldmax"]),
    ("endian", &["endian"]),
    ("encoding", &["encoding"]),
    ("line skip", &["lineskip"]),
    ("byte skip", &["byteskip"]),
    ("space units", &["spaceunits"]),
    ("space origin", &["spaceorigin"]),
    ("measurement frame", &["measurementframe"]),
    ("data file", &["datafile"]),
    ("sample units", &["sampleunits"]),
];

fn canonical_field(name: &str) -> Option<&'static str> {
    let squashed: String = name
        .chars()
        .filter(|c| !c.is_whitespace())
        .flat_map(char::to_lowercase)
        .collect();
    FIELDS
        .iter()
        .find(|(_, spellings)| spellings.contains(&squashed.as_str()))
        .map(|(canonical, _)| *canonical)
}

/// Named spaces and their dimension.
fn named_space_dimension(name: &str) -> Option<usize> {
    Some(match name.to_ascii_lowercase().as_str() {
        "right-anterior-superior"
        | "ras"
        | "left-anterior-superior"
        | "las"
        | "left-posterior-superior"
        | "lps"
        | "scanner-xyz"
        | "3d-right-handed"
        | "3d-left-handed" => 3,
        "right-anterior-superior-time"
        | "rast"
        | "left-anterior-superior-time"
        | "last"
        | "left-posterior-superior-time"
        | "lpst"
        | "scanner-xyz-time"
        | "3d-right-handed-time"
        | "3d-left-handed-time" => 4,
        _ => return None,
    })
}

/// Largest `dimension` accepted (teem's NRRD_DIM_MAX).
const MAX_DIMENSION: usize = 16;

/// Parses a NRRD header fed one line at a time.
#[derive(Debug, Default)]
pub(crate) struct HeaderParser {
    header: NrrdHeader,
    saw_magic: bool,
}

impl HeaderParser {
    pub fn new() -> Self {
        HeaderParser::default()
    }

    /// Parses line `line_no` (1-based, without its line terminator). Returns
    /// `Ok(false)` when the line ends the header (a blank line after the magic).
    pub fn line(&mut self, line_no: usize, text: &str) -> Result<bool, HeaderError> {
        let text = text.strip_suffix('\r').unwrap_or(text);
        if !self.saw_magic {
            let version = text.strip_prefix("NRRD000").unwrap_or("");
            if !matches!(version, "1" | "2" | "3" | "4" | "5") {
                let shown: String = text.chars().take(16).collect();
                return err(
                    line_no,
                    format!("not a NRRD file: expected `NRRD0001`…`NRRD0005`, found `{shown}`"),
                );
            }
            self.saw_magic = true;
            return Ok(true);
        }
        if text.trim().is_empty() {
            return Ok(false);
        }
        if text.starts_with('#') {
            return Ok(true);
        }
        let Some(colon) = text.find(':') else {
            return err(line_no, "expected `field: value` or `key:=value`");
        };
        let (name, rest) = (&text[..colon], &text[colon + 1..]);
        if let Some(value) = rest.strip_prefix('=') {
            self.header.key_values.push((name.to_string(), value.to_string()));
            return Ok(true);
        }
        let Some(field) = canonical_field(name) else {
            return err(line_no, format!("unknown field `{}`", name.trim()));
        };
        if self.header.lines.insert(field, line_no).is_some() {
            return err(line_no, format!("field `{field}` given twice"));
        }
        self.field(field, rest.trim())
            .map(|()| true)
            .or_else(|message| err(line_no, message))
    }

    fn field(&mut self, field: &str, value: &str) -> Result<(), String> {
        let h = &mut self.header;
        match field {
            "dimension" => {
                let d = parse_uint(value).ok_or_else(|| format!("bad dimension `{value}`"))?;
                if d == 0 || d > MAX_DIMENSION as u64 {
                    return Err(format!("dimension {d} outside 1..={MAX_DIMENSION}"));
                }
                h.dimension = d as usize;
            }
            "type" => {
                let t = value.to_ascii_lowercase();
                h.scalar = Some(ScalarType::parse(&t).ok_or_else(|| {
                    if matches!(
                        t.as_str(),
                        "block" | "longlong" | "ulonglong" | "long long" | "int64" | "uint64"
                    ) || t.contains("long")
                        || t.contains("64")
                    {
                        format!("unsupported type `{value}`")
                    } else {
                        format!("unknown type `{value}`")
                    }
                })?);
            }
            "sizes" => {
                h.sizes = words(value)
                    .map(|w| match parse_uint(w) {
                        Some(s) if s >= 1 => Ok(s),
                        _ => Err(format!("bad size `{w}` (sizes are integers ≥ 1)")),
                    })
                    .collect::<Result<_, _>>()?;
            }
            "encoding" => match value.to_ascii_lowercase().as_str() {
                "raw" => {}
                "txt" | "text" | "ascii" | "hex" | "gz" | "gzip" | "bz2" | "bzip2" | "zrl" => {
                    return Err(format!("unsupported encoding {value} (only raw is supported)"))
                }
                _ => return Err(format!("unknown encoding {value}")),
            },
            "endian" => {
                h.endian = Some(match value.to_ascii_lowercase().as_str() {
                    "little" => Endian::Little,
                    "big" => Endian::Big,
                    _ => return Err(format!("endian must be `little` or `big`, got `{value}`")),
                })
            }
            "space" => {
                let d = named_space_dimension(value).ok_or_else(|| format!("unknown space `{value}`"))?;
                if h.space_dimension.is_some() {
                    return Err("`space` and `space dimension` cannot both be given".into());
                }
                h.space_dimension = Some(d);
            }
            "space dimension" => {
                if h.space_dimension.is_some() {
                    return Err("`space` and `space dimension` cannot both be given".into());
                }
                match parse_uint(value) {
                    Some(d) if (1..=MAX_DIMENSION as u64).contains(&d) => h.space_dimension = Some(d as usize),
                    _ => return Err(format!("bad space dimension `{value}`")),
                }
            }
            "space directions" => {
                h.space_directions = Some(
                    parse_vector_list(value)?
                        .into_iter()
                        .map(|v| v.map(|v| v.to_vec()))
                        .collect(),
                );
            }
            "space origin" => {
                let mut list = parse_vector_list(value)?;
                match (list.pop(), list.is_empty()) {
                    (Some(Some(v)), true) => h.space_origin = Some(v),
                    _ => return Err(format!("space origin must be one vector, got `{value}`")),
                }
            }
            "spacings" => h.spacings = Some(parse_floats(value)?),
            "axis mins" => h.axis_mins = Some(parse_floats(value)?),
            "centers" => {
                h.centers = Some(
                    words(value)
                        .map(|w| match w.to_ascii_lowercase().as_str() {
                            "cell" => Ok(Center::Cell),
                            "node" => Ok(Center::Node),
                            "none" | "???" => Ok(Center::Unknown),
                            _ => Err(format!("unknown center `{w}`")),
                        })
                        .collect::<Result<_, _>>()?,
                )
            }
            "kinds" => h.kinds = Some(words(value).map(str::to_string).collect()),
            "data file" => {
                let mut w = words(value);
                match (w.next(), w.next()) {
                    (Some("LIST"), _) | (Some(_), Some(_)) => {
                        return Err(format!("multi-file data (`data file: {value}`) is not supported"))
                    }
                    (Some(name), None) => h.data_file = Some(name.to_string()),
                    (None, _) => return Err("empty data file name".into()),
                }
            }
            "line skip" => h.line_skip = parse_uint(value).ok_or_else(|| format!("bad line skip `{value}`"))?,
            "byte skip" => match value.parse::<i64>() {
                Ok(b) if b >= -1 => h.byte_skip = b,
                _ => return Err(format!("bad byte skip `{value}` (an integer ≥ -1)")),
            },
            // Accepted and not needed to place or decode the samples.
            _ => {}
        }
        Ok(())
    }

    /// Checks the header once all its lines are parsed; `end_line` is the line where
    /// it ended (for errors about missing fields).
    pub fn finish(self, end_line: usize) -> Result<NrrdHeader, HeaderError> {
        if !self.saw_magic {
            return err(end_line.max(1), "empty file: not a NRRD file");
        }
        let h = self.header;
        for required in ["dimension", "type", "sizes", "encoding"] {
            if h.line_of(required).is_none() {
                return err(end_line, format!("header ends without required field `{required}`"));
            }
        }
        let per_axis: [(&str, Option<usize>); 6] = [
            ("sizes", Some(h.sizes.len())),
            ("space directions", h.space_directions.as_ref().map(Vec::len)),
            ("spacings", h.spacings.as_ref().map(Vec::len)),
            ("axis mins", h.axis_mins.as_ref().map(Vec::len)),
            ("centers", h.centers.as_ref().map(Vec::len)),
            ("kinds", h.kinds.as_ref().map(Vec::len)),
        ];
        for (field, len) in per_axis {
            if let Some(len) = len {
                if len != h.dimension {
                    return err(
                        h.line_of(field).unwrap_or(end_line),
                        format!("`{field}` has {len} entries, dimension is {}", h.dimension),
                    );
                }
            }
        }
        if let Some(dirs) = &h.space_directions {
            let Some(sd) = h.space_dimension else {
                return err(
                    h.line_of("space directions").unwrap_or(end_line),
                    "`space directions` needs `space dimension` (or `space`)",
                );
            };
            if let Some(bad) = dirs.iter().flatten().find(|v| v.len() != sd) {
                return err(
                    h.line_of("space directions").unwrap_or(end_line),
                    format!("vector of {} components in a space of dimension {sd}", bad.len()),
                );
            }
        }
        if let Some(origin) = &h.space_origin {
            match h.space_dimension {
                Some(sd) if sd == origin.len() => {}
                Some(sd) => {
                    return err(
                        h.line_of("space origin").unwrap_or(end_line),
                        format!(
                            "space origin has {} components in a space of dimension {sd}",
                            origin.len()
                        ),
                    )
                }
                None => {
                    return err(
                        h.line_of("space origin").unwrap_or(end_line),
                        "`space origin` needs `space dimension` (or `space`)",
                    )
                }
            }
        }
        if h.space_directions.is_some() && h.spacings.is_some() {
            return err(
                h.line_of("spacings").unwrap_or(end_line),
                "`spacings` and `space directions` cannot both be given",
            );
        }
        if h.sample_count().is_none() {
            return err(
                h.line_of("sizes").unwrap_or(end_line),
                "sizes multiply beyond 2^64 samples",
            );
        }
        Ok(h)
    }
}

/// Parses a whole header text (lines up to the first blank line); for tests and
/// callers that hold the header in memory.
#[cfg(test)]
pub(crate) fn parse_header_text(text: &str) -> Result<NrrdHeader, HeaderError> {
    let mut parser = HeaderParser::new();
    let mut end = 0;
    for (i, line) in text.split('\n').enumerate() {
        end = i + 1;
        if !parser.line(end, line)? {
            break;
        }
    }
    parser.finish(end)
}

fn words(value: &str) -> impl Iterator<Item = &str> {
    value.split_whitespace()
}

fn parse_uint(s: &str) -> Option<u64> {
    if s.is_empty() || !s.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    s.parse().ok()
}

fn parse_float(s: &str) -> Result<f64, String> {
    s.trim()
        .parse::<f64>()
        .map_err(|_| format!("bad number `{}`", s.trim()))
}

fn parse_floats(value: &str) -> Result<Vec<f64>, String> {
    words(value).map(parse_float).collect()
}

/// Parses `(a,b,c) none (d,e,f)`: vectors (spaces allowed inside the parentheses)
/// or `none`.
fn parse_vector_list(value: &str) -> Result<Vec<Option<Vec<f64>>>, String> {
    let mut out = Vec::new();
    let mut rest = value.trim_start();
    while !rest.is_empty() {
        if let Some(after) = rest.strip_prefix('(') {
            let Some(close) = after.find(')') else {
                return Err(format!("unclosed `(` in `{value}`"));
            };
            let v = after[..close]
                .split(',')
                .map(parse_float)
                .collect::<Result<Vec<f64>, _>>()?;
            out.push(Some(v));
            rest = &after[close + 1..];
        } else if let Some(after) = rest.strip_prefix("none") {
            out.push(None);
            rest = after;
        } else {
            let shown: String = rest.chars().take(24).collect();
            return Err(format!("expected `(x,y,z)` or `none`, found `{shown}`"));
        }
        if !rest.is_empty() && !rest.starts_with(char::is_whitespace) {
            return Err(format!("expected a space between vectors in `{value}`"));
        }
        rest = rest.trim_start();
    }
    Ok(out)
}

/// Formats a number so that parsing it gives back the same `f64` (shortest round-trip
/// form, exponent for very large or small magnitudes). Exact zero is written `0`.
pub(crate) fn fmt_f64(x: f64) -> String {
    if x == 0.0 && x.is_sign_positive() {
        "0".to_string()
    } else {
        format!("{x:?}")
    }
}

/// `(x,y,z)` with [`fmt_f64`] components.
pub(crate) fn fmt_vector(v: &[f64]) -> String {
    let parts: Vec<String> = v.iter().map(|&x| fmt_f64(x)).collect();
    format!("({})", parts.join(","))
}

#[cfg(test)]
#[path = "nrrd_header_tests.rs"]
mod tests;
