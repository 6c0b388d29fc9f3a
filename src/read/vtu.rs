//! VTU (VTK XML UnstructuredGrid) reader.
//!
//! Reads every layout VTK, meshio and NGSolve write (docs/design.md §9): DataArray formats `ascii`,
//! `binary` (inline base64) and `appended` (raw or base64), UInt32/UInt64 headers, both byte
//! orders, zlib/LZ4/LZMA compression, any numeric type, and several `<Piece>` elements, which
//! are merged. The result is the file as written ([`VtuFile`]); turning it into a mesh is
//! [`crate::mesh`]'s job.
//!
//! The XML part is parsed with quick-xml up to `<AppendedData`, whose raw bytes are not XML.
//! All arrays are then decoded in parallel ([`super::decode`]).

use std::borrow::Cow;
use std::hash::{BuildHasher, Hasher};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use quick_xml::events::{BytesStart, Event};
use rayon::prelude::*;

use super::decode::{self, Compressor, Layout, Scalar};
use crate::error::{Error, Result, quote, shorten};
use crate::limits::Budget;

pub use super::cell_type;

/// One named point or cell array, values converted to `f64` (exact for every type except
/// 64-bit integers beyond 2^53, which no field or tag needs).
#[derive(Clone, Debug)]
pub struct DataArray {
    pub name: String,
    /// The type in the file.
    pub scalar: Scalar,
    pub components: usize,
    /// `ComponentName{i}` attributes, empty when absent.
    pub component_names: Vec<String>,
    /// Tuple-major: value `c` of tuple `i` is `values[i * components + c]`.
    pub values: Vec<f64>,
}

impl DataArray {
    /// Number of tuples.
    pub fn tuples(&self) -> usize {
        self.values.len() / self.components.max(1)
    }

    /// The array of the tuples `rows` (in that order, repeats allowed): a cell array carried
    /// to a subset of the cells, or to the pieces of split cells.
    pub fn rows(&self, rows: impl IntoIterator<Item = usize>) -> DataArray {
        let c = self.components;
        DataArray {
            name: self.name.clone(),
            scalar: self.scalar,
            components: c,
            component_names: self.component_names.clone(),
            values: rows
                .into_iter()
                .flat_map(|r| self.values[r * c..(r + 1) * c].iter().copied())
                .collect(),
        }
    }
}

/// How the file was written, for `inspect`.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct FileFormat {
    /// Data formats found: "ascii", "binary", "appended raw", "appended base64".
    pub data_formats: Vec<String>,
    pub compressor: String,
    pub header_type: String,
    pub byte_order: String,
    pub pieces: usize,
    /// Type of the point coordinates in the file.
    pub points_type: String,
    /// The container read and what was done to it ("VTU", "PVD step 0 of 1 (t = 0) → PVTU
    /// of 2 pieces (…)", "legacy VTK 5.1 BINARY"); set by [`super::container`].
    pub container: String,
}

/// A VTU file as written: points, VTK cells, point and cell arrays (pieces merged).
#[derive(Clone, Debug)]
pub struct VtuFile {
    pub path: PathBuf,
    pub points: Vec<[f64; 3]>,
    /// Components of the `Points` array in the file (3, or 2 for some writers).
    pub point_components: usize,
    /// VTK cell type of each cell.
    pub types: Vec<u8>,
    /// Cell `c` has nodes `connectivity[offsets[c]..offsets[c + 1]]` (`offsets[0] = 0`).
    pub offsets: Vec<usize>,
    pub connectivity: Vec<u32>,
    pub point_data: Vec<DataArray>,
    pub cell_data: Vec<DataArray>,
    /// Index of the first point of each `<Piece>`: pieces duplicate their interface points.
    pub piece_points: Vec<usize>,
    pub format: FileFormat,
}

impl VtuFile {
    /// Number of cells of any type.
    pub fn cell_count(&self) -> usize {
        self.types.len()
    }

    /// Nodes of cell `c`.
    pub fn cell(&self, c: usize) -> &[u32] {
        &self.connectivity[self.offsets[c]..self.offsets[c + 1]]
    }

    /// A file made in memory from points and `(VTK type, nodes)` cells, without arrays.
    pub fn from_cells(path: &Path, points: Vec<[f64; 3]>, cells: &[(u8, Vec<u32>)]) -> VtuFile {
        let mut offsets = vec![0];
        let mut connectivity = Vec::new();
        for (_, nodes) in cells {
            connectivity.extend_from_slice(nodes);
            offsets.push(connectivity.len());
        }
        VtuFile {
            path: path.to_path_buf(),
            points,
            point_components: 3,
            types: cells.iter().map(|c| c.0).collect(),
            offsets,
            connectivity,
            point_data: Vec::new(),
            cell_data: Vec::new(),
            piece_points: vec![0],
            format: FileFormat::default(),
        }
    }
}

/// Reads and decodes a VTU file.
///
/// The file's length is checked against the memory cap before anything is read, and the start
/// of a large file is checked ([`check_start`]) before the rest is read, so a large file that
/// is not VTK XML (zeros, an image, a tarball) is refused after reading a few kilobytes.
pub fn read_vtu(path: &Path) -> Result<VtuFile> {
    let bytes = crate::limits::read_bounded_checked(
        path,
        crate::limits::max_alloc(),
        "set FOSLS_MAX_ALLOC to raise it",
        check_start,
        |n| format!("is not a VTK XML file (no <VTKFile> element in its first {n} bytes)"),
    )?;
    parse_vtu(path, &bytes)
}

/// Decides from the first bytes of a file whether it can be VTK XML: after an optional UTF-8
/// byte order mark, whitespace, the XML declaration, processing instructions, comments and a
/// DOCTYPE, the first element must be `<VTKFile`. `Ok(true)`: it is; `Ok(false)`: more bytes
/// are needed; `Err((place, problem))`: it cannot be (the root element is another one, the
/// text is UTF-16, or some other byte stands where markup should start).
pub fn check_start(prefix: &[u8]) -> std::result::Result<bool, (String, String)> {
    if prefix.starts_with(b"\xff\xfe") || prefix.starts_with(b"\xfe\xff") {
        return Err((
            "file".into(),
            "is UTF-16 text; fosls reads VTK XML files in UTF-8".into(),
        ));
    }
    let start = if prefix.starts_with(b"\xef\xbb\xbf") {
        3
    } else {
        0
    };
    let mut at = start;
    loop {
        while at < prefix.len() && prefix[at].is_ascii_whitespace() {
            at += 1;
        }
        let s = &prefix[at..];
        if s.is_empty() {
            return Ok(false);
        }
        let skip =
            |open: usize, close: &[u8]| find(&s[open..], close).map(|e| open + e + close.len());
        let next = if s.starts_with(b"<?") {
            skip(2, b"?>")
        } else if s.starts_with(b"<!--") {
            skip(4, b"-->")
        } else if s.starts_with(b"<!DOCTYPE") {
            // Up to the '>' that is not inside the internal subset [ … ].
            match memchr::memchr(b'[', s) {
                Some(open) if memchr::memchr(b'>', s).is_none_or(|gt| open < gt) => {
                    find(&s[open..], b"]").and_then(|close| {
                        let after = open + close;
                        memchr::memchr(b'>', &s[after..]).map(|gt| after + gt + 1)
                    })
                }
                _ => memchr::memchr(b'>', s).map(|gt| gt + 1),
            }
        } else if s.starts_with(b"<!") || b"<!DOCTYPE".starts_with(s) || b"<!--".starts_with(s) {
            // Some other declaration, or one cut by the window: the parser decides.
            return Ok(s.len() >= 9);
        } else if s[0] == b'<' {
            let name_end = s[1..]
                .iter()
                .position(|&c| c.is_ascii_whitespace() || c == b'>' || c == b'/')
                .map(|p| p + 1);
            let Some(name_end) = name_end else {
                // The name runs to the end of the window.
                return Ok(false);
            };
            let name = String::from_utf8_lossy(&s[1..name_end]);
            if name == "VTKFile" {
                return Ok(true);
            }
            return Err((
                "root element".into(),
                format!("is <{}>, not <VTKFile>: not a VTK XML file", shorten(&name)),
            ));
        } else {
            let c = s[0];
            let shown = if c.is_ascii_graphic() {
                format!("'{}'", c as char)
            } else {
                format!("0x{c:02x}")
            };
            return Err((
                "file".into(),
                format!(
                    "is not a VTK XML file (byte {at} is {shown}, where the XML declaration or \
                     <VTKFile> should start)"
                ),
            ));
        };
        match next {
            Some(n) => at += n,
            None => return Ok(false),
        }
    }
}

/// The largest coordinate magnitude accepted by [`check_coordinates`]: lengths squared, areas
/// and the products the functional forms of a mesh reaching past it overflow (or come close
/// to overflowing) double precision, whose largest number is about 1.8e308.
pub const MAX_COORDINATE: f64 = 1e100;

/// The smallest nonzero extent of a mesh accepted by [`check_coordinates`]: below it, lengths
/// squared and areas underflow.
pub const MIN_EXTENT: f64 = 1e-100;

/// Refuses coordinates whose geometry cannot be computed in double precision: a point past
/// ±[`MAX_COORDINATE`] ("the coordinates overflow"), or a mesh whose extent is below
/// [`MIN_EXTENT`] ("the coordinates underflow"), with one line naming the point; a mesh builder
/// would otherwise report such a mesh as made of zero-area triangles.
pub fn check_coordinates(file: &VtuFile) -> Result<()> {
    let place = "Points array";
    if let Some((k, p)) = file
        .points
        .iter()
        .enumerate()
        .find(|(_, p)| p.iter().any(|v| v.abs() > MAX_COORDINATE))
    {
        return Err(Error::input(
            &file.path,
            place,
            format!(
                "point {k} is ({:e}, {:e}, {:e}): the coordinates overflow (beyond ±{MAX_COORDINATE:e}, \
                 lengths squared and areas are past what double precision holds); rescale the \
                 mesh",
                p[0], p[1], p[2]
            ),
        ));
    }
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in &file.points {
        for d in 0..3 {
            lo[d] = lo[d].min(p[d]);
            hi[d] = hi[d].max(p[d]);
        }
    }
    let extent = (0..3).map(|d| hi[d] - lo[d]).fold(0.0f64, f64::max);
    if extent > 0.0 && extent < MIN_EXTENT {
        return Err(Error::input(
            &file.path,
            place,
            format!(
                "the mesh spans only {extent:e}: the coordinates underflow (below \
                 {MIN_EXTENT:e}, lengths squared and areas are lost in double precision); \
                 rescale the mesh"
            ),
        ));
    }
    Ok(())
}

/// Refuses a boundary-tag array holding a value that is not a finite integer (NaN, ±∞, 2.5),
/// as `fosls inspect` does, with one line naming the cell: `arrays` are the cell arrays on the
/// line cells, `name` the scene's tag array (nothing to check when `None` or absent or not a
/// scalar array), `cell_of(l)` the file's cell number of line cell `l`.
pub fn check_tags(
    path: &Path,
    arrays: &[DataArray],
    name: Option<&str>,
    cell_of: impl Fn(usize) -> usize,
) -> Result<()> {
    let Some(a) = name.and_then(|n| arrays.iter().find(|a| a.name == n)) else {
        return Ok(());
    };
    if a.components != 1 {
        return Ok(());
    }
    match a
        .values
        .iter()
        .position(|v| !v.is_finite() || v.fract() != 0.0)
    {
        None => Ok(()),
        Some(l) => Err(Error::input(
            path,
            format!("cell array {}", quote(&a.name)),
            format!(
                "cell {} (a line cell) has the tag {}; boundary tags must be integers",
                cell_of(l),
                a.values[l]
            ),
        )),
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    Points,
    Connectivity,
    Offsets,
    Types,
    PointData,
    CellData,
}

impl Role {
    /// Index of the four arrays each piece has at most once (points and the three cell
    /// arrays).
    fn structural(self) -> Option<usize> {
        match self {
            Role::Points => Some(0),
            Role::Connectivity => Some(1),
            Role::Offsets => Some(2),
            Role::Types => Some(3),
            Role::PointData | Role::CellData => None,
        }
    }
}

#[derive(Debug)]
enum Source<'a> {
    Ascii(Cow<'a, [u8]>),
    Binary(Cow<'a, [u8]>),
    Appended(usize),
}

#[derive(Debug)]
struct ArraySpec<'a> {
    piece: usize,
    role: Role,
    /// Borrowed from the file for the points and cell arrays (unless it held a character
    /// reference); owned for point and cell data, copied while the parser has it at hand.
    name: Cow<'a, str>,
    /// [`NameHashes`] hash of the name, for point and cell data.
    hash: u64,
    scalar: Scalar,
    components: usize,
    component_names: Vec<String>,
    source: Source<'a>,
}

impl ArraySpec<'_> {
    fn place(&self, pieces: usize) -> String {
        let what = match self.role {
            Role::Points => "Points array".to_string(),
            Role::Connectivity => "Cells array \"connectivity\"".to_string(),
            Role::Offsets => "Cells array \"offsets\"".to_string(),
            Role::Types => "Cells array \"types\"".to_string(),
            Role::PointData => format!("point array {}", quote(&self.name)),
            Role::CellData => format!("cell array {}", quote(&self.name)),
        };
        if pieces > 1 {
            format!("Piece {}, {what}", self.piece)
        } else {
            what
        }
    }
}

#[derive(Debug, Default)]
struct PieceSpec {
    points: usize,
    cells: usize,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Tag {
    File,
    Grid,
    Piece,
    Points,
    Cells,
    PointData,
    CellData,
    DataArray,
    Other,
}

/// Attributes of one element, borrowed from the file where no normalisation was needed.
type Attrs<'a> = Vec<(Cow<'a, str>, Cow<'a, str>)>;

/// The appended-data section: its bytes (after the `_` marker) and its encoding.
struct Appended<'a> {
    data: &'a [u8],
    base64: bool,
    /// Sorted offsets of all appended arrays, to delimit base64 chunks.
    offsets: Vec<usize>,
}

/// `part` as a slice of `input` when it lies inside it (the events of a slice reader borrow
/// from the file): attributes can then be kept without copies.
fn within<'a>(input: &'a [u8], part: &str) -> Option<&'a str> {
    let start = (part.as_ptr() as usize).checked_sub(input.as_ptr() as usize)?;
    let bytes = input.get(start..start.checked_add(part.len())?)?;
    // The same memory as `part` (live allocations do not overlap): no need to compare them.
    debug_assert_eq!(bytes, part.as_bytes());
    std::str::from_utf8(bytes).ok()
}

/// The attributes of `e`, borrowed from `input` where possible (a file may hold many
/// elements: one copy per attribute was most of the cost of reading many small arrays).
fn attr_map<'a>(input: &'a [u8], e: &BytesStart<'_>) -> std::result::Result<Attrs<'a>, String> {
    let mut out = Vec::new();
    attr_map_into(input, e, &mut out)?;
    Ok(out)
}

/// The attributes in `raw` when they are all plain, `key="value"` or `key='value'` with
/// distinct keys and values holding no `&`, `<`, tab, newline or carriage return, which is how
/// writers write them: they are then exactly what quick-xml's parse and normalisation give
/// (keys up to `=`, values unchanged), found in one scan. `false` (and `out` partly filled)
/// for anything else, which quick-xml parses instead, with its own messages.
fn plain_attributes<'a>(raw: &'a str, out: &mut Attrs<'a>) -> bool {
    let b = raw.as_bytes();
    let space = |c: u8| matches!(c, b' ' | b'\t' | b'\n' | b'\r');
    let mut i = 0;
    loop {
        while i < b.len() && space(b[i]) {
            i += 1;
        }
        if i == b.len() {
            return true;
        }
        let key_start = i;
        while i < b.len() && b[i] != b'=' && !space(b[i]) {
            i += 1;
        }
        if i == key_start || i + 1 >= b.len() || b[i] != b'=' {
            return false;
        }
        let key = &raw[key_start..i];
        let quote = b[i + 1];
        if quote != b'"' && quote != b'\'' {
            return false;
        }
        let start = i + 2;
        let Some(len) = memchr::memchr(quote, &b[start..]) else {
            return false;
        };
        let value = &b[start..start + len];
        if memchr::memchr3(b'&', b'<', b'\t', value).is_some()
            || memchr::memchr2(b'\n', b'\r', value).is_some()
            || out.iter().any(|(k, _)| k == key)
        {
            return false;
        }
        out.push((Cow::Borrowed(key), Cow::Borrowed(&raw[start..start + len])));
        i = start + len + 1;
    }
}

/// [`attr_map`] into `out` (cleared first), so that one buffer serves every element.
fn attr_map_into<'a>(
    input: &'a [u8],
    e: &BytesStart<'_>,
    out: &mut Attrs<'a>,
) -> std::result::Result<(), String> {
    out.clear();
    if let Some(raw) = within(input, e.attributes_raw()) {
        if plain_attributes(raw, out) {
            return Ok(());
        }
        out.clear();
        let mut ok = true;
        for a in quick_xml::events::attributes::Attributes::new(raw, 0) {
            let Ok(a) = a else {
                ok = false;
                break;
            };
            let Ok(value) = a.normalized_value(quick_xml::XmlVersion::Implicit1_0) else {
                ok = false;
                break;
            };
            out.push((Cow::Borrowed(a.key.0), value));
        }
        if ok {
            return Ok(());
        }
        // An error: the messages (and their positions) are those of the element's own parse.
        out.clear();
    }
    for a in e.attributes() {
        let a = a.map_err(|err| format!("malformed attribute ({err})"))?;
        let key = a.key.as_ref().to_string();
        let value = a
            .normalized_value(quick_xml::XmlVersion::Implicit1_0)
            .map_err(|err| format!("malformed attribute {key} ({err})"))?
            .into_owned();
        out.push((Cow::Owned(key), Cow::Owned(value)));
    }
    Ok(())
}

fn get<'m>(attrs: &'m [(Cow<'_, str>, Cow<'_, str>)], key: &str) -> Option<&'m str> {
    attrs
        .iter()
        .find(|(k, _)| k == key)
        .map(|(_, v)| v.as_ref())
}

fn text_bytes(t: Cow<'_, str>) -> Cow<'_, [u8]> {
    match t {
        Cow::Borrowed(s) => Cow::Borrowed(s.as_bytes()),
        Cow::Owned(s) => Cow::Owned(s.into_bytes()),
    }
}

fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    memchr::memmem::find(haystack, needle)
}

/// The appended-data section whose start tag `e` ends at byte `tag_end`: its encoding, and its
/// bytes from the `_` marker to the last `</AppendedData>`.
fn appended_section<'a>(
    path: &Path,
    bytes: &'a [u8],
    e: &BytesStart<'_>,
    tag_end: usize,
) -> Result<Appended<'a>> {
    let err = |problem: &str| Error::input(path, "<AppendedData>", problem);
    let attrs = attr_map(bytes, e).map_err(|problem| err(&problem))?;
    let base64 = match get(&attrs, "encoding") {
        Some("base64") => true,
        Some("raw") => false,
        _ => {
            return Err(err(
                "missing or unknown encoding (expected \"raw\" or \"base64\")",
            ));
        }
    };
    let tag_end = tag_end.min(bytes.len());
    let underscore = bytes[tag_end..]
        .iter()
        .position(|&c| c == b'_')
        .map(|p| tag_end + p + 1)
        .ok_or_else(|| err("no '_' marker before the data (truncated file?)"))?;
    let end = memchr::memmem::rfind(bytes, b"</AppendedData>")
        .filter(|&e| e >= underscore)
        .ok_or_else(|| err("no closing </AppendedData> tag (truncated file?)"))?;
    let mut data = &bytes[underscore..end];
    if base64 {
        data = data.trim_ascii_end();
    }
    Ok(Appended {
        data,
        base64,
        offsets: Vec::new(),
    })
}

/// What the later stages need to know of the specs, gathered as each is made (a file may hold
/// many arrays: passes over all the specs afterwards were a tenth of the time of reading
/// 50,000 arrays).
#[derive(Default)]
struct SpecIndex {
    /// Formats in order of first appearance ("appended" stands for either appended format).
    formats: Vec<&'static str>,
    /// The first appended array, and the offsets of all.
    first_appended: Option<usize>,
    offsets: Vec<usize>,
    /// By piece: structural arrays counted and the first of each, number of specs, point and
    /// cell arrays counted.
    counts: Vec<[usize; 4]>,
    first: Vec<[usize; 4]>,
    specs: Vec<usize>,
    data: Vec<[usize; 2]>,
}

impl SpecIndex {
    /// Records spec `s`, number `i`.
    fn add(&mut self, s: &ArraySpec, i: usize) {
        let f = match s.source {
            Source::Ascii(_) => "ascii",
            Source::Binary(_) => "binary",
            Source::Appended(off) => {
                self.first_appended.get_or_insert(i);
                self.offsets.push(off);
                "appended"
            }
        };
        if !self.formats.contains(&f) {
            self.formats.push(f);
        }
        self.pieces(s.piece + 1);
        let p = s.piece;
        self.specs[p] += 1;
        match s.role.structural() {
            Some(k) => {
                self.counts[p][k] += 1;
                if self.first[p][k] == usize::MAX {
                    self.first[p][k] = i;
                }
            }
            None => self.data[p][usize::from(s.role == Role::CellData)] += 1,
        }
    }

    /// Makes room for `n` pieces.
    fn pieces(&mut self, n: usize) {
        if self.specs.len() < n {
            self.counts.resize(n, [0; 4]);
            self.first.resize(n, [usize::MAX; 4]);
            self.specs.resize(n, 0);
            self.data.resize(n, [0; 2]);
        }
    }
}

/// Parses the bytes of a VTU file (see [`read_vtu`]), with the global memory cap
/// ([`crate::limits::max_alloc`]).
pub fn parse_vtu(path: &Path, bytes: &[u8]) -> Result<VtuFile> {
    parse_vtu_with(path, bytes, &Budget::global())
}

/// Parses the bytes of a VTU file, reserving every decoded array (and every intermediate byte
/// buffer whose size the file declares) from `budget` before allocating it; afterwards
/// `budget.used()` is the file's declared data size as held in memory.
pub fn parse_vtu_with(path: &Path, bytes: &[u8], budget: &Budget) -> Result<VtuFile> {
    let err = |place: &str, problem: String| Error::input(path, place, problem);
    if bytes.iter().all(u8::is_ascii_whitespace) {
        return Err(err("file", "is empty".into()));
    }

    // The XML part ends at the start tag of <AppendedData>, found by the XML parser (so a
    // comment or CDATA section that mentions it is not taken for it): its raw bytes are not
    // XML and are never given to the parser.
    let mut appended: Option<Appended> = None;
    let mut reader = quick_xml::Reader::from_reader(bytes);
    let mut stack: Vec<Tag> = Vec::new();
    let mut seen_root = false;
    let mut layout = Layout {
        header_u64: false,
        big_endian: false,
        compressor: Compressor::None,
    };
    let mut format = FileFormat {
        compressor: "none".into(),
        header_type: "UInt32".into(),
        byte_order: "LittleEndian".into(),
        ..FileFormat::default()
    };
    let mut pieces: Vec<PieceSpec> = Vec::new();
    let mut specs: Vec<ArraySpec> = Vec::new();
    let mut index = SpecIndex::default();
    // The DataArray being read: its section; its attributes and text segments are in buffers
    // kept from one array to the next (a file may hold many arrays), as are the attributes of
    // the other elements.
    let mut current: Option<Tag> = None;
    let mut array_attrs: Attrs = Vec::new();
    let mut texts: Vec<Cow<[u8]>> = Vec::new();
    let mut scratch: Attrs = Vec::new();
    let hashes = NameHashes::new();

    loop {
        let pos = reader.buffer_position();
        let event = reader.read_event().map_err(|e| {
            err(
                &format!("byte {}", reader.error_position()),
                format!("not well-formed XML ({e})"),
            )
        })?;
        let (start, empty) = match &event {
            Event::Start(e) => (Some(e.clone()), false),
            Event::Empty(e) => (Some(e.clone()), true),
            _ => (None, false),
        };
        if let Some(e) = start {
            let name = e.name();
            let name = name.as_ref();
            let parent = stack.last().copied();
            if name == "AppendedData" && parent.is_some() {
                let tag_end = reader.buffer_position() as usize;
                appended = Some(appended_section(path, bytes, &e, tag_end)?);
                break;
            }
            let tag = match (parent, name) {
                (None, "VTKFile") => Tag::File,
                (None, other) => {
                    return Err(err(
                        "root element",
                        format!("is <{}>, not <VTKFile>: not a VTK XML file", shorten(other)),
                    ));
                }
                (Some(Tag::File), "UnstructuredGrid") => Tag::Grid,
                (
                    Some(Tag::File),
                    "PolyData" | "ImageData" | "RectilinearGrid" | "StructuredGrid",
                ) => {
                    return Err(err(
                        "<VTKFile>",
                        format!(
                            "holds <{}>; fosls reads UnstructuredGrid (.vtu) files",
                            shorten(name)
                        ),
                    ));
                }
                (Some(Tag::Grid), "Piece") => Tag::Piece,
                (Some(Tag::Piece), "Points") => Tag::Points,
                (Some(Tag::Piece), "Cells") => Tag::Cells,
                (Some(Tag::Piece), "PointData") => Tag::PointData,
                (Some(Tag::Piece), "CellData") => Tag::CellData,
                (Some(Tag::Points | Tag::Cells | Tag::PointData | Tag::CellData), "DataArray") => {
                    Tag::DataArray
                }
                _ => Tag::Other,
            };
            let attrs = if tag == Tag::DataArray {
                &mut array_attrs
            } else {
                &mut scratch
            };
            attr_map_into(bytes, &e, attrs)
                .map_err(|problem| err(&format!("<{name}> at byte {pos}"), problem))?;
            let attrs = &*attrs;
            match tag {
                Tag::File => {
                    seen_root = true;
                    if let Some(t) = get(attrs, "type")
                        && t != "UnstructuredGrid"
                    {
                        return Err(err(
                            "<VTKFile>",
                            format!(
                                "type is {}; fosls reads UnstructuredGrid (.vtu) files",
                                quote(t)
                            ),
                        ));
                    }
                    match get(attrs, "byte_order").unwrap_or("LittleEndian") {
                        "LittleEndian" => {}
                        "BigEndian" => {
                            layout.big_endian = true;
                            format.byte_order = "BigEndian".into();
                        }
                        other => {
                            return Err(err(
                                "<VTKFile> byte_order",
                                format!("{} is neither LittleEndian nor BigEndian", quote(other)),
                            ));
                        }
                    }
                    match get(attrs, "header_type").unwrap_or("UInt32") {
                        "UInt32" => {}
                        "UInt64" => {
                            layout.header_u64 = true;
                            format.header_type = "UInt64".into();
                        }
                        other => {
                            return Err(err(
                                "<VTKFile> header_type",
                                format!("{} is neither UInt32 nor UInt64", quote(other)),
                            ));
                        }
                    }
                    let c = get(attrs, "compressor").unwrap_or("");
                    layout.compressor = Compressor::parse(c).ok_or_else(|| {
                        err(
                            "<VTKFile> compressor",
                            format!(
                                "{} is not supported (vtkZLibDataCompressor, \
                                 vtkLZ4DataCompressor, vtkLZMADataCompressor)",
                                quote(c)
                            ),
                        )
                    })?;
                    format.compressor = layout.compressor.name().into();
                }
                Tag::Piece => {
                    let count = |key: &str| -> Result<usize> {
                        let v = get(attrs, key).ok_or_else(|| {
                            err(
                                &format!("Piece {}", pieces.len()),
                                format!("missing attribute {key}"),
                            )
                        })?;
                        v.trim().parse::<usize>().map_err(|_| {
                            err(
                                &format!("Piece {} {key}", pieces.len()),
                                format!("{} is not a non-negative integer", quote(v)),
                            )
                        })
                    };
                    pieces.push(PieceSpec {
                        points: count("NumberOfPoints")?,
                        cells: count("NumberOfCells")?,
                    });
                }
                Tag::DataArray => {
                    let section = parent.unwrap_or(Tag::Other);
                    texts.clear();
                    if empty {
                        let spec = finish_array(
                            path,
                            pieces.len(),
                            section,
                            &mut array_attrs,
                            &mut texts,
                            &hashes,
                        )?;
                        if let Some(s) = spec {
                            index.add(&s, specs.len());
                            specs.push(s);
                        }
                    } else {
                        current = Some(section);
                    }
                }
                _ => {}
            }
            if !empty {
                stack.push(tag);
            }
            continue;
        }
        match event {
            Event::Text(t) if stack.last() == Some(&Tag::DataArray) && current.is_some() => {
                texts.push(text_bytes(t.into_inner()));
            }
            Event::CData(t) if stack.last() == Some(&Tag::DataArray) && current.is_some() => {
                texts.push(text_bytes(t.into_inner()));
            }
            Event::End(_) => {
                if stack.pop() == Some(Tag::DataArray)
                    && let Some(section) = current.take()
                    && let Some(s) = finish_array(
                        path,
                        pieces.len(),
                        section,
                        &mut array_attrs,
                        &mut texts,
                        &hashes,
                    )?
                {
                    index.add(&s, specs.len());
                    specs.push(s);
                }
            }
            Event::Eof => break,
            _ => {}
        }
    }

    if !seen_root {
        return Err(err(
            "file",
            "is not a VTK XML file (no <VTKFile> element)".into(),
        ));
    }
    let expected_depth = if appended.is_some() { 1 } else { 0 };
    if stack.len() > expected_depth {
        let inside = match stack.last() {
            Some(Tag::DataArray) => "<DataArray>",
            Some(Tag::Piece) => "<Piece>",
            Some(Tag::Points) => "<Points>",
            Some(Tag::Cells) => "<Cells>",
            Some(Tag::PointData) => "<PointData>",
            Some(Tag::CellData) => "<CellData>",
            Some(Tag::Grid) => "<UnstructuredGrid>",
            _ => "<VTKFile>",
        };
        return Err(err(
            "file",
            format!("ends inside {inside} (truncated file?)"),
        ));
    }
    if pieces.is_empty() {
        return Err(err("<UnstructuredGrid>", "has no <Piece>".into()));
    }

    index.pieces(pieces.len());
    if let Some(i) = index.first_appended {
        let Some(a) = appended.as_mut() else {
            return Err(err(
                &specs[i].place(pieces.len()),
                "format is \"appended\" but the file has no <AppendedData> section".into(),
            ));
        };
        a.offsets = std::mem::take(&mut index.offsets);
        a.offsets.sort_unstable();
        a.offsets.dedup();
    }
    let appended_name = match &appended {
        Some(a) if a.base64 => "appended base64",
        _ => "appended raw",
    };
    format.data_formats = index
        .formats
        .iter()
        .map(|&f| if f == "appended" { appended_name } else { f }.to_string())
        .collect();
    format.pieces = pieces.len();

    // Every piece needs points and the three cell arrays (counted as the specs were made: a
    // file may hold many pieces).
    let counts = &index.counts;
    for (p, piece) in pieces.iter().enumerate() {
        // Only built for a message (a file may hold many pieces).
        let place = || {
            if pieces.len() > 1 {
                format!("Piece {p}")
            } else {
                "Piece".to_string()
            }
        };
        for (role, what) in [
            (Role::Points, "a Points array"),
            (Role::Connectivity, "a Cells array \"connectivity\""),
            (Role::Offsets, "a Cells array \"offsets\""),
            (Role::Types, "a Cells array \"types\""),
        ] {
            let n = role.structural().map_or(0, |k| counts[p][k]);
            let needed = match role {
                Role::Points => piece.points > 0,
                _ => piece.cells > 0,
            };
            if n == 0 && needed {
                return Err(err(&place(), format!("has no {what}")));
            }
            if n > 1 {
                return Err(err(&place(), format!("has more than one {what}")));
            }
        }
    }

    // Decode all arrays in parallel, straight into their places (an indexed collect: no list
    // of chunks to concatenate). The first failing array in file order is reported, whatever
    // the threads' timing, and the arrays after it are skipped.
    let npieces = pieces.len();
    let first_failed = AtomicUsize::new(usize::MAX);
    let failure: Mutex<Option<(usize, String)>> = Mutex::new(None);
    let decoded: Vec<Option<Decoded>> = specs
        .par_iter()
        .enumerate()
        .map(|(i, s)| {
            if i > first_failed.load(Ordering::Relaxed) {
                return None;
            }
            let piece = &pieces[s.piece];
            let tuples = match s.role {
                Role::Points | Role::PointData => Some(piece.points),
                Role::Offsets | Role::Types | Role::CellData => Some(piece.cells),
                Role::Connectivity => None,
            };
            match decode_array(s, tuples, &layout, appended.as_ref(), budget) {
                Ok(d) => Some(d),
                Err(problem) => {
                    first_failed.fetch_min(i, Ordering::Relaxed);
                    let mut f = failure.lock().unwrap_or_else(|e| e.into_inner());
                    if f.as_ref().is_none_or(|&(k, _)| i < k) {
                        *f = Some((i, problem));
                    }
                    None
                }
            }
        })
        .collect();
    if let Some((i, problem)) = failure.into_inner().unwrap_or_else(|e| e.into_inner()) {
        return Err(err(&specs[i].place(npieces), problem));
    }

    assemble(path, &pieces, &mut specs, &index, decoded, format)
}

enum Decoded {
    Float(Vec<f64>),
    /// Integers, and the first value that does not fit in i64 (held as `i64::MIN`) as written
    /// in the file, for messages: `(index, value)`.
    Int(Vec<i64>, Option<(usize, u64)>),
}

/// Integer `v` at `index` as the file wrote it (UInt64 values past i64 are held as i64::MIN).
fn true_value(v: i64, index: usize, big: Option<(usize, u64)>) -> String {
    match big {
        Some((k, t)) if k == index && v == i64::MIN => t.to_string(),
        _ => v.to_string(),
    }
}

/// Turns a DataArray's attributes and text into a spec; `None` for arrays fosls does not use
/// (polyhedron faces). The name and the text are moved out of `attrs` and `texts`, which the
/// caller reuses.
fn finish_array<'a>(
    path: &Path,
    piece_count: usize,
    section: Tag,
    attrs: &mut Attrs<'a>,
    texts: &mut Vec<Cow<'a, [u8]>>,
    hashes: &NameHashes,
) -> Result<Option<ArraySpec<'a>>> {
    let piece = piece_count.saturating_sub(1);
    let name: Cow<'a, str> = match attrs.iter_mut().find(|(k, _)| k == "Name") {
        Some((_, v)) => std::mem::take(v),
        None => Cow::Borrowed(""),
    };
    let role = match section {
        Tag::Points => Role::Points,
        Tag::Cells => match name.as_ref() {
            "connectivity" => Role::Connectivity,
            "offsets" => Role::Offsets,
            "types" => Role::Types,
            _ => return Ok(None),
        },
        Tag::PointData => Role::PointData,
        _ => Role::CellData,
    };
    // The other attributes fosls reads, in one pass (the first of each key, as `get` finds).
    let (mut ty, mut comps, mut form, mut offset, mut named) = (None, None, None, None, false);
    for (k, v) in attrs.iter() {
        let slot = match k.as_ref() {
            "type" => &mut ty,
            "NumberOfComponents" => &mut comps,
            "format" => &mut form,
            "offset" => &mut offset,
            k => {
                named |= k.starts_with("ComponentName");
                continue;
            }
        };
        if slot.is_none() {
            *slot = Some(v.as_ref());
        }
    }
    // The place is only built for a message (a file may hold many arrays).
    let err = |problem: String| {
        let named = ArraySpec {
            piece,
            role,
            name: Cow::Borrowed(name.as_ref()),
            hash: 0,
            scalar: Scalar::Float64,
            components: 1,
            component_names: Vec::new(),
            source: Source::Appended(0),
        };
        Error::input(path, named.place(piece_count), problem)
    };
    if matches!(role, Role::PointData | Role::CellData) && name.is_empty() {
        return Err(err("has no Name attribute".into()));
    }
    let ty = ty.ok_or_else(|| err("missing attribute type".into()))?;
    let scalar = Scalar::parse(ty).ok_or_else(|| err(format!("unknown type {}", quote(ty))))?;
    let mut components = 1;
    if let Some(c) = comps {
        components = c
            .trim()
            .parse::<usize>()
            .ok()
            .filter(|&c| (1..=1024).contains(&c))
            .ok_or_else(|| {
                err(format!(
                    "NumberOfComponents {} is not an integer in 1..=1024",
                    quote(c)
                ))
            })?;
    }
    // Component names by index, in one pass over the attributes (an element may hold many).
    let mut component_names = Vec::new();
    if named {
        let mut names: Vec<Option<&str>> = vec![None; components];
        for (k, v) in attrs.iter() {
            if let Some(i) = k
                .strip_prefix("ComponentName")
                .and_then(|i| i.parse::<usize>().ok().filter(|n| n.to_string() == i))
                && i < names.len()
                && names[i].is_none()
            {
                names[i] = Some(v.as_ref());
            }
        }
        for n in names {
            match n {
                Some(n) => component_names.push(n.to_string()),
                None => break,
            }
        }
        if component_names.len() != components {
            component_names.clear();
        }
    }
    let mut text = || -> Cow<'a, [u8]> {
        if texts.len() == 1 {
            texts.pop().unwrap_or_default()
        } else {
            let joined = Cow::Owned(texts.concat());
            texts.clear();
            joined
        }
    };
    let source = match form.unwrap_or("ascii") {
        "ascii" => Source::Ascii(text()),
        "binary" => Source::Binary(text()),
        "appended" => {
            let off = offset.ok_or_else(|| err("appended array without offset".into()))?;
            Source::Appended(off.trim().parse::<usize>().map_err(|_| {
                err(format!(
                    "offset {} is not a non-negative integer",
                    quote(off)
                ))
            })?)
        }
        other => {
            return Err(err(format!(
                "format {} is not ascii, binary or appended",
                quote(other)
            )));
        }
    };
    let (name, hash) = match role {
        Role::PointData | Role::CellData => {
            let hash = hashes.hash_one(name.as_ref());
            (Cow::Owned(name.into_owned()), hash)
        }
        _ => (name, 0),
    };
    Ok(Some(ArraySpec {
        piece,
        role,
        name,
        hash,
        scalar,
        components,
        component_names,
        source,
    }))
}

fn decode_array(
    spec: &ArraySpec,
    tuples: Option<usize>,
    layout: &Layout,
    appended: Option<&Appended>,
    budget: &Budget,
) -> decode::DecodeResult<Decoded> {
    let integer = matches!(spec.role, Role::Connectivity | Role::Offsets | Role::Types);
    if integer && !spec.scalar.is_integer() {
        return Err(format!(
            "has type {}, expected an integer type",
            spec.scalar.name()
        ));
    }
    let expected = match tuples {
        Some(t) => Some(
            t.checked_mul(spec.components)
                .filter(|&n| n.checked_mul(spec.scalar.size()).is_some())
                .ok_or_else(|| "declared size overflows".to_string())?,
        ),
        None => None,
    };
    let expected_bytes = expected.map(|n| (n * spec.scalar.size()) as u64);
    let raw: Vec<u8>;
    let data: &[u8] = match &spec.source {
        Source::Ascii(text) => {
            // parse_ascii allocates at most one value per two characters of text.
            let values = expected.unwrap_or(usize::MAX).min(text.len() / 2 + 1);
            budget.reserve(values as u64 * 8, "the array")?;
            let out = if integer {
                let v: Vec<i64> = decode::parse_ascii(text, spec.scalar, expected)?;
                // A value past i64 is held as i64::MIN: keep the first one as written.
                let big = v.iter().position(|&x| x == i64::MIN).and_then(|k| {
                    let token = std::str::from_utf8(text)
                        .ok()?
                        .split_ascii_whitespace()
                        .nth(k)?;
                    Some((k, token.parse::<u64>().ok()?))
                });
                Decoded::Int(v, big)
            } else {
                Decoded::Float(decode::parse_ascii(text, spec.scalar, expected)?)
            };
            return check_count(out, expected, spec.components);
        }
        Source::Binary(text) => {
            raw = decode::base64_decode(text)?;
            &raw
        }
        Source::Appended(off) => {
            let a = appended.ok_or("no appended data")?;
            if *off >= a.data.len() {
                return Err(format!(
                    "appended offset {off} is past the end of the appended data ({} bytes)",
                    a.data.len()
                ));
            }
            if a.base64 {
                // The next offset (sorted: a binary search, for files with many arrays).
                let next = a
                    .offsets
                    .get(a.offsets.partition_point(|&o| o <= *off))
                    .copied()
                    .unwrap_or(a.data.len())
                    .min(a.data.len());
                raw = decode::base64_decode(&a.data[*off..next])?;
                &raw
            } else {
                &a.data[*off..]
            }
        }
    };
    let payload = decode::payload(data, layout, expected_bytes)?;
    let direct = spec.scalar == Scalar::Float64 && !layout.big_endian && !integer;
    // Values are held as 8-byte numbers; other types inflate into a byte buffer first.
    let values = (payload.len() / spec.scalar.size()) as u64;
    let staging = match (&payload, direct) {
        (decode::Payload::Blocks { .. }, false) => payload.len() as u64,
        _ => 0,
    };
    budget.reserve(values * 8 + staging, "the array")?;
    let out = if direct {
        // The common case decodes straight into the result: no intermediate byte buffer.
        let mut v = vec![0.0f64; payload.len() / 8];
        if !payload.len().is_multiple_of(8) {
            return Err(format!(
                "{} bytes of data is not a whole number of Float64 values",
                payload.len()
            ));
        }
        payload.decode_into(bytemuck::cast_slice_mut(&mut v))?;
        Decoded::Float(v)
    } else {
        let bytes = payload.bytes()?;
        if integer {
            let v: Vec<i64> = decode::convert(&bytes, spec.scalar, layout.big_endian)?;
            // UInt64 values past i64 are held as i64::MIN: keep the first one in its type.
            let big = (spec.scalar == Scalar::UInt64)
                .then(|| v.iter().position(|&x| x == i64::MIN))
                .flatten()
                .and_then(|k| {
                    let raw: [u8; 8] = bytes.get(8 * k..8 * k + 8)?.try_into().ok()?;
                    let t = if layout.big_endian {
                        u64::from_be_bytes(raw)
                    } else {
                        u64::from_le_bytes(raw)
                    };
                    Some((k, t))
                });
            Decoded::Int(v, big)
        } else {
            Decoded::Float(decode::convert(&bytes, spec.scalar, layout.big_endian)?)
        }
    };
    check_count(out, expected, spec.components)
}

fn check_count(
    out: Decoded,
    expected: Option<usize>,
    components: usize,
) -> decode::DecodeResult<Decoded> {
    let n = match &out {
        Decoded::Float(v) => v.len(),
        Decoded::Int(v, _) => v.len(),
    };
    match expected {
        Some(e) if e != n => Err(format!(
            "holds {n} values, but {components} components × {} tuples need {e}",
            e / components.max(1)
        )),
        None if n % components != 0 => Err(format!(
            "holds {n} values, not a multiple of its {components} components"
        )),
        _ => Ok(out),
    }
}

/// Hashes of array names for [`assemble`]'s map: a folded multiply per 8 bytes with keys drawn
/// for each file from the standard library's random state (whose SipHash was an eighth of the
/// time of reading 50,000 arrays). The keys are secret, so a file cannot choose names that
/// collide; a collision would only cost time, never a wrong result.
#[derive(Clone, Copy)]
struct NameHashes {
    seed: u64,
    k1: u64,
    k2: u64,
}

impl NameHashes {
    fn new() -> NameHashes {
        let random = std::hash::RandomState::new();
        NameHashes {
            seed: random.hash_one(1u64),
            k1: random.hash_one(2u64),
            k2: random.hash_one(3u64) | 1,
        }
    }
}

impl BuildHasher for NameHashes {
    type Hasher = NameHasher;
    fn build_hasher(&self) -> NameHasher {
        NameHasher {
            h: self.seed,
            k1: self.k1,
            k2: self.k2,
        }
    }
}

struct NameHasher {
    h: u64,
    k1: u64,
    k2: u64,
}

impl NameHasher {
    fn mix(&mut self, w: u64) {
        let p = u128::from(self.h ^ w ^ self.k1) * u128::from(self.k2);
        self.h = (p as u64) ^ ((p >> 64) as u64);
    }
}

impl Hasher for NameHasher {
    fn write(&mut self, bytes: &[u8]) {
        let mut chunks = bytes.chunks_exact(8);
        for c in &mut chunks {
            let mut w = [0u8; 8];
            w.copy_from_slice(c);
            self.mix(u64::from_le_bytes(w));
        }
        let rest = chunks.remainder();
        let mut w = [0u8; 8];
        w[..rest.len()].copy_from_slice(rest);
        self.mix(u64::from_le_bytes(w) ^ ((rest.len() as u64) << 59));
    }

    fn write_u8(&mut self, i: u8) {
        self.mix(u64::from(i) ^ (1 << 63));
    }

    fn finish(&self) -> u64 {
        let p = u128::from(self.h ^ self.k2) * u128::from(self.k1 | 1);
        (p as u64) ^ ((p >> 64) as u64)
    }
}

/// An array name with its hash, computed while the parser had the name at hand (hashing it
/// again here, from memory long out of the cache, was most of the cost of the name map).
struct NameKey<'s> {
    hash: u64,
    name: &'s str,
}

impl<'s> NameKey<'s> {
    fn of(s: &'s ArraySpec) -> NameKey<'s> {
        NameKey {
            hash: s.hash,
            name: s.name.as_ref(),
        }
    }
}

impl PartialEq for NameKey<'_> {
    fn eq(&self, other: &Self) -> bool {
        self.hash == other.hash && self.name == other.name
    }
}

impl Eq for NameKey<'_> {}

impl std::hash::Hash for NameKey<'_> {
    fn hash<H: Hasher>(&self, state: &mut H) {
        state.write_u64(self.hash);
    }
}

/// Hashes a [`NameKey`] to its kept hash.
#[derive(Clone, Copy, Default)]
struct KeptHash;

impl BuildHasher for KeptHash {
    type Hasher = Kept;
    fn build_hasher(&self) -> Kept {
        Kept(0)
    }
}

struct Kept(u64);

impl Hasher for Kept {
    fn write(&mut self, bytes: &[u8]) {
        // Only `write_u64` is used; anything else is folded in.
        for &b in bytes {
            self.0 = self.0.rotate_left(8) ^ u64::from(b);
        }
    }

    fn write_u64(&mut self, i: u64) {
        self.0 ^= i;
    }

    fn finish(&self) -> u64 {
        self.0
    }
}

fn assemble(
    path: &Path,
    pieces: &[PieceSpec],
    specs: &mut [ArraySpec],
    index: &SpecIndex,
    mut decoded: Vec<Option<Decoded>>,
    mut format: FileFormat,
) -> Result<VtuFile> {
    let err = |place: &str, problem: String| Error::input(path, place, problem);
    let total_points: usize = pieces.iter().map(|p| p.points).sum();
    if total_points > u32::MAX as usize {
        return Err(err(
            "Piece",
            format!("{total_points} points is more than fosls handles (2^32)"),
        ));
    }
    let mut file = VtuFile {
        path: path.to_path_buf(),
        points: Vec::with_capacity(total_points),
        point_components: 3,
        types: Vec::new(),
        offsets: vec![0],
        connectivity: Vec::new(),
        point_data: Vec::new(),
        cell_data: Vec::new(),
        piece_points: Vec::new(),
        format: FileFormat::default(),
    };
    // Arrays by piece (a file may hold many pieces and many arrays): the specs are in file
    // order, so those of piece `p` are `specs[starts[p]..starts[p + 1]]`, with `data[p]` point
    // and cell arrays.
    let first = &index.first;
    let data = &index.data;
    let mut starts = Vec::with_capacity(pieces.len() + 1);
    starts.push(0);
    for n in &index.specs {
        starts.push(starts.last().copied().unwrap_or(0) + n);
    }
    let mut take = |p: usize, role: Role| -> Option<(usize, Decoded)> {
        let i = first[p][role.structural()?];
        if i == usize::MAX {
            return None;
        }
        decoded[i].take().map(|d| (i, d))
    };
    let npieces = pieces.len();
    let mut point_base = 0usize;
    for (p, piece) in pieces.iter().enumerate() {
        file.piece_points.push(point_base);
        if let Some((i, Decoded::Float(v))) = take(p, Role::Points) {
            let s = &specs[i];
            if !(s.components == 2 || s.components == 3) {
                return Err(err(
                    &s.place(npieces),
                    format!("has {} components; points need 3 (or 2)", s.components),
                ));
            }
            file.point_components = s.components;
            format.points_type = s.scalar.name().into();
            for (k, c) in v.chunks_exact(s.components).enumerate() {
                let x = [c[0], c[1], if s.components == 3 { c[2] } else { 0.0 }];
                if !x.iter().all(|v| v.is_finite()) {
                    return Err(err(
                        &s.place(npieces),
                        format!(
                            "point {} has a non-finite coordinate ({}, {}, {})",
                            point_base + k,
                            x[0],
                            x[1],
                            x[2]
                        ),
                    ));
                }
                file.points.push(x);
            }
        }
        if piece.cells > 0 {
            let (oi, Decoded::Int(offsets, obig)) =
                take(p, Role::Offsets).ok_or_else(|| err("Cells", "no offsets".into()))?
            else {
                return Err(err("Cells", "offsets are not integers".into()));
            };
            let (ci, Decoded::Int(conn, cbig)) = take(p, Role::Connectivity)
                .ok_or_else(|| err("Cells", "no connectivity".into()))?
            else {
                return Err(err("Cells", "connectivity is not integer".into()));
            };
            let (ti, Decoded::Int(types, _)) =
                take(p, Role::Types).ok_or_else(|| err("Cells", "no types".into()))?
            else {
                return Err(err("Cells", "types are not integers".into()));
            };
            // The places are only built for a message (a file may hold many pieces).
            let oplace = || specs[oi].place(npieces);
            let cplace = || specs[ci].place(npieces);
            let tplace = || specs[ti].place(npieces);
            let conn_base = file.connectivity.len();
            let mut prev = 0i64;
            for (c, &o) in offsets.iter().enumerate() {
                if o < prev || o > conn.len() as i64 {
                    return Err(err(
                        &oplace(),
                        format!(
                            "offset {} of cell {c} is {} (connectivity has {} entries)",
                            true_value(o, c, obig),
                            if o < prev && o != i64::MIN {
                                "smaller than the one before"
                            } else {
                                "past the end of the connectivity"
                            },
                            conn.len()
                        ),
                    ));
                }
                let t = types[c];
                let cell = file.types.len();
                let kind = u8::try_from(t).ok();
                let known = kind.map(cell_type::fixed_nodes);
                if known.is_none() || known == Some(Some(0)) {
                    return Err(err(
                        &tplace(),
                        format!(
                            "cell {cell} has unsupported VTK cell type {t} ({}); fosls reads \
                             vertices (1), lines (3), triangles (5), polygons of 3 or 4 vertices \
                             (7), pixels (8), quads (9), quadratic edges (21), triangles (22) and \
                             quads (23, 28), and Lagrange curves, triangles and quadrilaterals \
                             (68, 69, 70)",
                            cell_type::name(u8::try_from(t).unwrap_or(0))
                        ),
                    ));
                }
                let count = (o - prev) as usize;
                if let Some(nodes) = known.flatten()
                    && count != nodes
                {
                    return Err(err(
                        &oplace(),
                        format!(
                            "cell {cell} ({}) has {count} nodes, expected {nodes}",
                            cell_type::name(t as u8),
                        ),
                    ));
                }
                if count == 0 {
                    return Err(err(&oplace(), format!("cell {cell} has no nodes")));
                }
                file.types.push(t as u8);
                file.offsets.push(conn_base + o as usize);
                prev = o;
            }
            if prev as usize != conn.len() {
                return Err(err(
                    &cplace(),
                    format!("has {} entries but the offsets end at {prev}", conn.len()),
                ));
            }
            for (k, &v) in conn.iter().enumerate() {
                if v < 0 || v as usize >= piece.points {
                    return Err(err(
                        &cplace(),
                        format!(
                            "entry {k} refers to point {}, but the piece has {} points",
                            true_value(v, k, cbig),
                            piece.points
                        ),
                    ));
                }
                file.connectivity.push((point_base + v as usize) as u32);
            }
        }
        point_base += piece.points;
    }

    // Point and cell arrays: the first piece sets names and components, the others must match.
    // Names are hashed once, in piece 0; a later piece marks each array it meets with its own
    // number, so a name met twice in one piece is found without a set per piece.
    for (r, role) in [Role::PointData, Role::CellData].into_iter().enumerate() {
        // (spec, values) of each array of piece 0, in file order.
        let mut merged: Vec<(usize, Vec<f64>)> = Vec::new();
        let mut by_name: std::collections::HashMap<NameKey, usize, KeptHash> =
            std::collections::HashMap::with_capacity_and_hasher(
                data.first().map_or(0, |d| d[r]),
                KeptHash,
            );
        let mut seen_in: Vec<usize> = Vec::new();
        for p in 0..npieces {
            let count = data[p][r];
            if p > 0 && count != merged.len() {
                return Err(err(
                    &format!("Piece {p}"),
                    format!(
                        "has {count} {} arrays, piece 0 has {}",
                        if role == Role::PointData {
                            "point"
                        } else {
                            "cell"
                        },
                        merged.len()
                    ),
                ));
            }
            for i in starts[p]..starts[p + 1] {
                let s = &specs[i];
                if s.role != role {
                    continue;
                }
                let Some(Decoded::Float(values)) = decoded[i].take() else {
                    continue;
                };
                if p == 0 {
                    if by_name.insert(NameKey::of(s), merged.len()).is_some() {
                        return Err(err(&s.place(npieces), "appears twice".into()));
                    }
                    merged.push((i, values));
                    continue;
                }
                let Some(&k) = by_name.get(&NameKey::of(s)) else {
                    return Err(err(&s.place(npieces), "is not in piece 0".into()));
                };
                if seen_in[k] == p {
                    return Err(err(&s.place(npieces), "appears twice".into()));
                }
                seen_in[k] = p;
                let (a, into) = &mut merged[k];
                let components = specs[*a].components;
                if components != s.components {
                    return Err(err(
                        &s.place(npieces),
                        format!("has {} components, {components} in piece 0", s.components),
                    ));
                }
                into.extend_from_slice(&values);
            }
            if p == 0 {
                seen_in = vec![0; merged.len()];
            }
        }
        drop(by_name);
        // The names and component names move from the specs: one copy, only of names that
        // were not borrowed from the file.
        let arrays = merged
            .into_iter()
            .map(|(i, values)| {
                let s = &mut specs[i];
                DataArray {
                    name: std::mem::take(&mut s.name).into_owned(),
                    scalar: s.scalar,
                    components: s.components,
                    component_names: std::mem::take(&mut s.component_names),
                    values,
                }
            })
            .collect();
        match role {
            Role::PointData => file.point_data = arrays,
            _ => file.cell_data = arrays,
        }
    }
    file.format = format;
    Ok(file)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<VtuFile> {
        parse_vtu(Path::new("t.vtu"), text.as_bytes())
    }

    const ASCII: &str = r#"<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian">
<UnstructuredGrid>
<Piece NumberOfPoints="4" NumberOfCells="3">
<Points><DataArray type="Float64" NumberOfComponents="3" format="ascii">
0 0 0  1 0 0  0 1 0  1 1 0
</DataArray></Points>
<Cells>
<DataArray type="Int64" Name="connectivity" format="ascii">0 1 2 1 3 2 0 1</DataArray>
<DataArray type="Int64" Name="offsets" format="ascii">3 6 8</DataArray>
<DataArray type="UInt8" Name="types" format="ascii">5 5 3</DataArray>
</Cells>
<PointData><DataArray type="Float32" Name="u" NumberOfComponents="2" ComponentName0="ux" ComponentName1="uy" format="ascii">
0 0 1 0 0 1 1 1</DataArray>
<DataArray type="Float64" Name="p" format="ascii">1 2 3 4</DataArray></PointData>
<CellData><DataArray type="Int32" Name="tag" format="ascii">0 0 7</DataArray></CellData>
</Piece></UnstructuredGrid></VTKFile>
"#;

    #[test]
    fn reads_an_ascii_file() {
        let f = parse(ASCII).unwrap();
        assert_eq!(f.points.len(), 4);
        assert_eq!(f.types, vec![5, 5, 3]);
        assert_eq!(f.cell(1), &[1, 3, 2]);
        assert_eq!(f.cell(2), &[0, 1]);
        assert_eq!(f.point_data[0].name, "u");
        assert_eq!(f.point_data[0].components, 2);
        assert_eq!(f.point_data[0].component_names, vec!["ux", "uy"]);
        assert_eq!(f.point_data[1].components, 1);
        assert_eq!(f.cell_data[0].values, vec![0.0, 0.0, 7.0]);
        assert_eq!(f.format.data_formats, vec!["ascii"]);
    }

    #[test]
    fn wrong_component_count_is_named() {
        let bad = ASCII.replace("0 0 1 0 0 1 1 1</DataArray>", "0 0 1 0 0 1 1</DataArray>");
        let e = parse(&bad).unwrap_err().to_string();
        assert_eq!(
            e,
            "t.vtu: point array \"u\": holds 7 values, but 2 components × 4 tuples need 8"
        );
    }

    #[test]
    fn unknown_cell_type_is_named() {
        let bad = ASCII.replace(">5 5 3<", ">5 20 3<");
        let e = parse(&bad).unwrap_err().to_string();
        assert!(
            e.starts_with(
                "t.vtu: Cells array \"types\": cell 1 has unsupported VTK cell type 20 \
                 (unknown VTK cell type)"
            ),
            "{e}"
        );
    }

    #[test]
    fn truncated_xml_is_named() {
        let cut = &ASCII[..ASCII.find("<CellData>").unwrap()];
        let e = parse(cut).unwrap_err().to_string();
        assert_eq!(e, "t.vtu: file: ends inside <Piece> (truncated file?)");
    }

    #[test]
    fn not_xml_and_empty() {
        assert_eq!(parse("").unwrap_err().to_string(), "t.vtu: file: is empty");
        let e = parse("hello world").unwrap_err().to_string();
        assert_eq!(
            e,
            "t.vtu: file: is not a VTK XML file (no <VTKFile> element)"
        );
        let e = parse("<html><body/></html>").unwrap_err().to_string();
        assert_eq!(
            e,
            "t.vtu: root element: is <html>, not <VTKFile>: not a VTK XML file"
        );
    }

    #[test]
    fn connectivity_out_of_range() {
        let bad = ASCII.replace(">0 1 2 1 3 2 0 1<", ">0 1 2 1 4 2 0 1<");
        let e = parse(&bad).unwrap_err().to_string();
        assert_eq!(
            e,
            "t.vtu: Cells array \"connectivity\": entry 4 refers to point 4, but the piece has 4 points"
        );
    }

    /// Appended raw data, zlib compressed, UInt64 header, big endian: built by hand.
    #[test]
    fn reads_appended_raw_compressed_big_endian() {
        use std::io::Write;
        fn block(raw: &[u8]) -> Vec<u8> {
            let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
            z.write_all(raw).unwrap();
            let c = z.finish().unwrap();
            let mut out = Vec::new();
            for v in [1u64, raw.len() as u64, raw.len() as u64, c.len() as u64] {
                out.extend_from_slice(&v.to_be_bytes());
            }
            out.extend_from_slice(&c);
            out
        }
        let pts: Vec<u8> = [0.0f64, 0., 0., 1., 0., 0., 0., 1., 0.]
            .iter()
            .flat_map(|v| v.to_be_bytes())
            .collect();
        let conn: Vec<u8> = [0i32, 1, 2].iter().flat_map(|v| v.to_be_bytes()).collect();
        let offs: Vec<u8> = 3i32.to_be_bytes().to_vec();
        let types = vec![5u8];
        let mut data = Vec::new();
        let mut offsets = Vec::new();
        for a in [&pts, &conn, &offs, &types] {
            offsets.push(data.len());
            data.extend_from_slice(&block(a));
        }
        let file = |points_offset: usize| {
            let head = format!(
                r#"<VTKFile type="UnstructuredGrid" version="1.0" byte_order="BigEndian" header_type="UInt64" compressor="vtkZLibDataCompressor">
<UnstructuredGrid><Piece NumberOfPoints="3" NumberOfCells="1">
<Points><DataArray type="Float64" NumberOfComponents="3" format="appended" offset="{}"/></Points>
<Cells><DataArray type="Int32" Name="connectivity" format="appended" offset="{}"/>
<DataArray type="Int32" Name="offsets" format="appended" offset="{}"/>
<DataArray type="UInt8" Name="types" format="appended" offset="{}"/></Cells>
</Piece></UnstructuredGrid>
<AppendedData encoding="raw">
_"#,
                points_offset, offsets[1], offsets[2], offsets[3]
            );
            let mut bytes = head.into_bytes();
            bytes.extend_from_slice(&data);
            bytes.extend_from_slice(b"\n</AppendedData></VTKFile>\n");
            bytes
        };
        let f = parse_vtu(Path::new("t.vtu"), &file(offsets[0])).unwrap();
        assert_eq!(f.points[1], [1.0, 0.0, 0.0]);
        assert_eq!(f.cell(0), &[0, 1, 2]);
        assert_eq!(f.format.data_formats, vec!["appended raw"]);
        assert_eq!(f.format.byte_order, "BigEndian");

        let e = parse_vtu(Path::new("t.vtu"), &file(999_999))
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            format!(
                "t.vtu: Points array: appended offset 999999 is past the end of the appended data ({} bytes)",
                data.len() + 1
            )
        );
    }

    /// The one-scan parse of plain attributes gives what quick-xml gives, and leaves anything
    /// else to quick-xml.
    #[test]
    fn plain_attributes_match_quick_xml() {
        let quick = |raw: &str| -> Option<Vec<(String, String)>> {
            quick_xml::events::attributes::Attributes::new(raw, 0)
                .map(|a| {
                    let a = a.ok()?;
                    let v = a
                        .normalized_value(quick_xml::XmlVersion::Implicit1_0)
                        .ok()?;
                    Some((a.key.0.to_string(), v.into_owned()))
                })
                .collect()
        };
        let cases = [
            (" type=\"Float64\" Name=\"a0\" format=\"ascii\"", true),
            ("", true),
            ("   ", true),
            (" a='1'\tb=\"x y\"\n", true),
            (" a=\"1\"b=\"2\"", true),
            (" a=\"\"", true),
            (" a=\"é≠\" é=\"'\"", true),
            (" a=\"1\" a=\"2\"", false),
            (" a = \"1\"", false),
            (" a=1", false),
            (" a=\"1", false),
            (" a", false),
            (" =\"1\"", false),
            (" a=\"&amp;\"", false),
            (" a=\"x\ny\"", false),
            (" a=\"x\ty\"", false),
            (" a=\"x\ry\"", false),
            (" a=\"<\"", false),
            (" a=\"1\" /", false),
        ];
        for (raw, plain) in cases {
            let mut out = Vec::new();
            assert_eq!(plain_attributes(raw, &mut out), plain, "{raw:?}");
            if plain {
                let mine: Vec<(String, String)> = out
                    .iter()
                    .map(|(k, v)| (k.to_string(), v.to_string()))
                    .collect();
                assert_eq!(Some(mine), quick(raw), "{raw:?}");
            }
        }
    }

    #[test]
    fn several_pieces_are_merged() {
        let piece = |off: &str| {
            format!(
                r#"<Piece NumberOfPoints="3" NumberOfCells="1">
<Points><DataArray type="Float64" NumberOfComponents="3" format="ascii">{off} 0 0 1 0 0 0 1 0</DataArray></Points>
<Cells><DataArray type="Int32" Name="connectivity" format="ascii">0 1 2</DataArray>
<DataArray type="Int32" Name="offsets" format="ascii">3</DataArray>
<DataArray type="UInt8" Name="types" format="ascii">5</DataArray></Cells>
<PointData><DataArray type="Float64" Name="s" format="ascii">1 2 3</DataArray></PointData>
</Piece>"#
            )
        };
        let text = format!(
            "<VTKFile type=\"UnstructuredGrid\"><UnstructuredGrid>{}{}</UnstructuredGrid></VTKFile>",
            piece("0"),
            piece("5")
        );
        let f = parse(&text).unwrap();
        assert_eq!(f.points.len(), 6);
        assert_eq!(f.cell(1), &[3, 4, 5]);
        assert_eq!(f.point_data[0].values, vec![1., 2., 3., 1., 2., 3.]);
        assert_eq!(f.format.pieces, 2);
    }
}
