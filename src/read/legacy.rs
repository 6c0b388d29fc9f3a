//! Legacy VTK files (`.vtk`), `DATASET UNSTRUCTURED_GRID`, ASCII and BINARY (big-endian),
//! versions 2.0 to 5.1, as sfepy, meshio and many converters write them.
//!
//! Sections: `POINTS n type`; `CELLS n size` with a count before each cell's nodes (versions
//! 2–4), or `CELLS n+1 size` followed by `OFFSETS type` and `CONNECTIVITY type` (5.x; told apart
//! by the keyword that follows, not by the version); `CELL_TYPES n`; `POINT_DATA n` and
//! `CELL_DATA n` with `SCALARS` (and its `LOOKUP_TABLE`), `COLOR_SCALARS`, `VECTORS`, `NORMALS`,
//! `TEXTURE_COORDINATES`, `TENSORS` (9 components, row-major), `TENSORS6` and `FIELD` arrays.
//! Data-set `FIELD` data and `METADATA` blocks are skipped, except a `COMPONENT_NAMES` block,
//! which names the components of the array before it. The result is the same [`VtuFile`] the
//! VTU reader gives.

use std::path::Path;

use super::cell_type;
use super::decode::{self, Scalar};
use super::vtu::{DataArray, FileFormat, VtuFile};
use crate::error::{Error, Result};
use crate::limits::Budget;

/// Reads a legacy VTK file.
pub fn read_legacy(path: &Path) -> Result<VtuFile> {
    let bytes = super::container::read_bytes(path)?;
    parse_legacy(path, &bytes, &Budget::global())
}

/// A legacy data type: its scalar, or `bit` (not read).
fn scalar(name: &str) -> Option<Scalar> {
    Some(match name.to_ascii_lowercase().as_str() {
        "unsigned_char" | "vtktypeuint8" => Scalar::UInt8,
        "char" | "signed_char" | "vtktypeint8" => Scalar::Int8,
        "unsigned_short" | "vtktypeuint16" => Scalar::UInt16,
        "short" | "vtktypeint16" => Scalar::Int16,
        "unsigned_int" | "vtktypeuint32" => Scalar::UInt32,
        // VTK writes vtkIdType as a 32-bit int in legacy files.
        "int" | "vtktypeint32" | "vtkidtype" => Scalar::Int32,
        "unsigned_long" | "vtktypeuint64" | "unsigned_long_long" => Scalar::UInt64,
        "long" | "vtktypeint64" | "long_long" => Scalar::Int64,
        "float" | "vtktypefloat32" => Scalar::Float32,
        "double" | "vtktypefloat64" => Scalar::Float64,
        _ => return None,
    })
}

/// `%20` and other `%XX` escapes VTK writes in array names.
fn unescape(name: &str) -> String {
    let b = name.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%'
            && i + 2 < b.len()
            && let Some(v) = std::str::from_utf8(&b[i + 1..i + 3])
                .ok()
                .and_then(|h| u8::from_str_radix(h, 16).ok())
        {
            out.push(v);
            i += 3;
            continue;
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8(out).unwrap_or_else(|_| name.to_string())
}

/// The file being read: a cursor over its bytes.
struct Cursor<'a> {
    path: &'a Path,
    bytes: &'a [u8],
    pos: usize,
    binary: bool,
    budget: &'a Budget,
}

/// Values as read: integers for cells, floats for everything else.
enum Values {
    Float(Vec<f64>),
    Int(Vec<i64>),
}

impl<'a> Cursor<'a> {
    /// "line L" (ASCII files) or "byte B" (binary files) of byte `at`.
    fn at(&self, at: usize) -> String {
        if self.binary {
            format!("byte {at}")
        } else {
            let at = at.min(self.bytes.len());
            format!(
                "line {}",
                memchr::memchr_iter(b'\n', &self.bytes[..at]).count() + 1
            )
        }
    }

    fn err(&self, at: usize, what: &str, problem: impl std::fmt::Display) -> Error {
        let place = if what.is_empty() {
            self.at(at)
        } else {
            format!("{what} ({})", self.at(at))
        };
        Error::input(self.path, place, problem)
    }

    /// The next line as is (without its end), or `None` at the end of the file.
    fn raw_line(&mut self) -> Option<(usize, &'a str)> {
        if self.pos >= self.bytes.len() {
            return None;
        }
        let start = self.pos;
        let end =
            memchr::memchr(b'\n', &self.bytes[start..]).map_or(self.bytes.len(), |e| start + e);
        self.pos = (end + 1).min(self.bytes.len());
        let text = std::str::from_utf8(&self.bytes[start..end]).unwrap_or("\u{fffd}");
        Some((start, text.trim_end_matches('\r')))
    }

    /// The next non-blank line, trimmed.
    fn line(&mut self) -> Option<(usize, &'a str)> {
        while let Some((at, l)) = self.raw_line() {
            if !l.trim().is_empty() {
                return Some((at, l.trim()));
            }
        }
        None
    }

    /// The first word of the next non-blank line, without moving.
    fn peek_word(&self) -> &'a str {
        let mut p = self.pos;
        while p < self.bytes.len() && self.bytes[p].is_ascii_whitespace() {
            p += 1;
        }
        let e = self.bytes[p..]
            .iter()
            .position(|c| c.is_ascii_whitespace())
            .map_or(self.bytes.len(), |e| p + e);
        std::str::from_utf8(&self.bytes[p..e]).unwrap_or("")
    }

    /// `n` values of type `s` from here: whitespace-separated numbers (ASCII) or big-endian
    /// binary data starting right after the header line.
    fn values(&mut self, n: usize, s: Scalar, integer: bool, what: &str) -> Result<Values> {
        let start = self.pos;
        let remaining = self.bytes.len() - self.pos;
        if self.binary {
            let need = n.checked_mul(s.size()).ok_or_else(|| {
                self.err(start, what, format!("{n} values overflow the file size"))
            })?;
            if need > remaining {
                return Err(self.err(
                    start,
                    what,
                    format!(
                        "needs {need} bytes of {} data but the file has {remaining} left \
                         (truncated file?)",
                        s.name()
                    ),
                ));
            }
            self.budget
                .reserve(n as u64 * 8, "the array")
                .map_err(|m| self.err(start, what, m))?;
            let data = &self.bytes[self.pos..self.pos + need];
            self.pos += need;
            let out = if integer {
                Values::Int(decode::convert(data, s, true).map_err(|m| self.err(start, what, m))?)
            } else {
                Values::Float(decode::convert(data, s, true).map_err(|m| self.err(start, what, m))?)
            };
            return Ok(out);
        }
        // ASCII: each value takes a character and a separator.
        if n > remaining / 2 + 1 {
            return Err(self.err(
                start,
                what,
                format!(
                    "declares {n} values but only {remaining} bytes are left (truncated file?)"
                ),
            ));
        }
        self.budget
            .reserve(n as u64 * 8, "the array")
            .map_err(|m| self.err(start, what, m))?;
        let mut ints = Vec::new();
        let mut floats = Vec::new();
        if integer {
            ints.reserve(n);
        } else {
            floats.reserve(n);
        }
        for i in 0..n {
            let b = self.bytes;
            while self.pos < b.len() && b[self.pos].is_ascii_whitespace() {
                self.pos += 1;
            }
            let t0 = self.pos;
            while self.pos < b.len() && !b[self.pos].is_ascii_whitespace() {
                self.pos += 1;
            }
            if t0 == self.pos {
                return Err(self.err(
                    start,
                    what,
                    format!("ends after {i} of {n} values (truncated file?)"),
                ));
            }
            let token = std::str::from_utf8(&b[t0..self.pos]).unwrap_or("\u{fffd}");
            if integer {
                let v = token.parse::<i64>().map_err(|_| {
                    self.err(t0, what, format!("value {i} '{token}' is not an integer"))
                })?;
                ints.push(v);
            } else {
                let v = token.parse::<f64>().or_else(|_| {
                    match token.to_ascii_lowercase().as_str() {
                        "nan" | "-nan" => Ok(f64::NAN),
                        "inf" | "infinity" => Ok(f64::INFINITY),
                        "-inf" | "-infinity" => Ok(f64::NEG_INFINITY),
                        _ => {
                            Err(self.err(t0, what, format!("value {i} '{token}' is not a number")))
                        }
                    }
                })?;
                floats.push(v);
            }
        }
        Ok(if integer {
            Values::Int(ints)
        } else {
            Values::Float(floats)
        })
    }

    fn floats(&mut self, n: usize, s: Scalar, what: &str) -> Result<Vec<f64>> {
        match self.values(n, s, false, what)? {
            Values::Float(v) => Ok(v),
            Values::Int(v) => Ok(v.into_iter().map(|x| x as f64).collect()),
        }
    }

    fn ints(&mut self, n: usize, s: Scalar, what: &str) -> Result<Vec<i64>> {
        if !s.is_integer() {
            return Err(self.err(
                self.pos,
                what,
                format!("has type {}, expected an integer type", s.name()),
            ));
        }
        match self.values(n, s, true, what)? {
            Values::Int(v) => Ok(v),
            Values::Float(v) => Ok(v.into_iter().map(|x| x as i64).collect()),
        }
    }

    /// Skips a `METADATA` block (up to a blank line); returns the names of its
    /// `COMPONENT_NAMES` block, if any.
    fn metadata(&mut self) -> Vec<String> {
        let mut names = Vec::new();
        let mut in_names = false;
        while let Some((_, l)) = self.raw_line() {
            let l = l.trim();
            if l.is_empty() {
                break;
            }
            if l == "COMPONENT_NAMES" {
                in_names = true;
            } else if l.starts_with("INFORMATION") {
                in_names = false;
            } else if in_names {
                names.push(unescape(l));
            }
        }
        names
    }
}

/// Which attribute section an array belongs to.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Section {
    None,
    Point,
    Cell,
}

/// Parses a legacy VTK file (module doc), reserving decoded arrays from `budget`.
pub fn parse_legacy(path: &Path, bytes: &[u8], budget: &Budget) -> Result<VtuFile> {
    let mut c = Cursor {
        path,
        bytes,
        pos: 0,
        binary: false,
        budget,
    };
    if bytes.iter().all(u8::is_ascii_whitespace) {
        return Err(Error::input(path, "file", "is empty"));
    }
    let (_, header) = c.raw_line().unwrap_or((0, ""));
    let version = header
        .trim()
        .strip_prefix('#')
        .map(str::trim_start)
        .filter(|h| h.to_ascii_lowercase().starts_with("vtk datafile version"))
        .map(|h| h["vtk DataFile Version".len()..].trim().to_string())
        .ok_or_else(|| {
            Error::input(
                path,
                "line 1",
                "is not a legacy VTK header ('# vtk DataFile Version x.x')",
            )
        })?;
    if c.raw_line().is_none() {
        return Err(Error::input(
            path,
            "line 2",
            "missing title line (truncated file?)",
        ));
    }
    let (at, mode) = c
        .line()
        .ok_or_else(|| Error::input(path, "line 3", "missing ASCII or BINARY (truncated file?)"))?;
    match mode.to_ascii_uppercase().as_str() {
        "ASCII" => {}
        "BINARY" => c.binary = true,
        other => {
            return Err(c.err(at, "", format!("'{other}' is neither ASCII nor BINARY")));
        }
    }
    let (at, dataset) = c
        .line()
        .ok_or_else(|| c.err(c.pos, "", "no DATASET line (truncated file?)"))?;
    let mut w = dataset.split_whitespace();
    if !w.next().is_some_and(|k| k.eq_ignore_ascii_case("DATASET")) {
        return Err(c.err(at, "", format!("expected DATASET, found '{dataset}'")));
    }
    let kind = w.next().unwrap_or("");
    if !kind.eq_ignore_ascii_case("UNSTRUCTURED_GRID") {
        return Err(c.err(
            at,
            "DATASET",
            format!("is {kind}; fosls reads DATASET UNSTRUCTURED_GRID"),
        ));
    }

    let mut points: Option<(Vec<f64>, Scalar)> = None;
    let mut offsets: Option<Vec<i64>> = None;
    let mut connectivity: Option<Vec<i64>> = None;
    let mut types: Option<Vec<i64>> = None;
    let mut cells_at = 0usize;
    let mut point_data: Vec<DataArray> = Vec::new();
    let mut cell_data: Vec<DataArray> = Vec::new();
    let mut section = Section::None;
    let mut count = 0usize;
    // Where the last array went, for a COMPONENT_NAMES block after it.
    let mut last: Option<Section> = None;

    let number = |c: &Cursor, at: usize, what: &str, word: Option<&str>| -> Result<usize> {
        let w = word.ok_or_else(|| c.err(at, what, "is missing its count"))?;
        w.parse::<usize>().map_err(|_| {
            c.err(
                at,
                what,
                format!("count '{w}' is not a non-negative integer"),
            )
        })
    };
    let type_of = |c: &Cursor, at: usize, what: &str, word: Option<&str>| -> Result<Scalar> {
        let w = word.ok_or_else(|| c.err(at, what, "is missing its data type"))?;
        scalar(w).ok_or_else(|| c.err(at, what, format!("data type '{w}' is not supported")))
    };

    while let Some((at, l)) = c.line() {
        let mut w = l.split_whitespace();
        let key = w.next().unwrap_or("").to_ascii_uppercase();
        match key.as_str() {
            "POINTS" => {
                let n = number(&c, at, "POINTS", w.next())?;
                let s = type_of(&c, at, "POINTS", w.next())?;
                let v = c.floats(
                    n.checked_mul(3)
                        .ok_or_else(|| c.err(at, "POINTS", "count overflows"))?,
                    s,
                    "POINTS",
                )?;
                points = Some((v, s));
            }
            "CELLS" => {
                let n = number(&c, at, "CELLS", w.next())?;
                let size = number(&c, at, "CELLS", w.next())?;
                cells_at = at;
                if c.peek_word().eq_ignore_ascii_case("OFFSETS") {
                    // 5.x: n offsets (one more than the cells), then the connectivity.
                    let (oat, ol) = c.line().unwrap_or((at, ""));
                    let s = type_of(&c, oat, "OFFSETS", ol.split_whitespace().nth(1))?;
                    let o = c.ints(n, s, "OFFSETS")?;
                    let (cat, cl) = c.line().ok_or_else(|| {
                        c.err(c.pos, "CELLS", "no CONNECTIVITY (truncated file?)")
                    })?;
                    let mut cw = cl.split_whitespace();
                    if !cw
                        .next()
                        .is_some_and(|k| k.eq_ignore_ascii_case("CONNECTIVITY"))
                    {
                        return Err(c.err(
                            cat,
                            "CELLS",
                            format!("expected CONNECTIVITY after the OFFSETS, found '{cl}'"),
                        ));
                    }
                    let s = type_of(&c, cat, "CONNECTIVITY", cw.next())?;
                    let conn = c.ints(size, s, "CONNECTIVITY")?;
                    if n == 0 || o.first() != Some(&0) || *o.last().unwrap_or(&0) != size as i64 {
                        return Err(c.err(
                            oat,
                            "OFFSETS",
                            format!(
                                "must run from 0 to the connectivity size {size} (found {} \
                                 offsets{})",
                                o.len(),
                                match (o.first(), o.last()) {
                                    (Some(a), Some(b)) => format!(", {a} to {b}"),
                                    _ => String::new(),
                                }
                            ),
                        ));
                    }
                    offsets = Some(o[1..].to_vec());
                    connectivity = Some(conn);
                } else {
                    // 2–4: per cell a node count, then the nodes.
                    let list = c.ints(size, Scalar::Int32, "CELLS")?;
                    let mut o = Vec::with_capacity(n);
                    let mut conn = Vec::with_capacity(size.saturating_sub(n));
                    let mut k = 0usize;
                    for cell in 0..n {
                        let m = *list.get(k).ok_or_else(|| {
                            c.err(
                                at,
                                "CELLS",
                                format!(
                                    "the list of {size} numbers ends at cell {cell} of {n} (the \
                                     size does not match the cells)"
                                ),
                            )
                        })?;
                        if m < 0 || k + 1 + m as usize > list.len() {
                            return Err(c.err(
                                at,
                                "CELLS",
                                format!(
                                    "cell {cell} declares {m} nodes, past the end of the list of \
                                     {size} numbers"
                                ),
                            ));
                        }
                        conn.extend_from_slice(&list[k + 1..k + 1 + m as usize]);
                        k += 1 + m as usize;
                        o.push(conn.len() as i64);
                    }
                    if k != list.len() {
                        return Err(c.err(
                            at,
                            "CELLS",
                            format!(
                                "size {size} does not match the {n} cells, which take {k} numbers"
                            ),
                        ));
                    }
                    offsets = Some(o);
                    connectivity = Some(conn);
                }
            }
            "CELL_TYPES" => {
                let n = number(&c, at, "CELL_TYPES", w.next())?;
                types = Some(c.ints(n, Scalar::Int32, "CELL_TYPES")?);
            }
            "POINT_DATA" | "CELL_DATA" => {
                count = number(&c, at, &key, w.next())?;
                section = if key == "POINT_DATA" {
                    Section::Point
                } else {
                    Section::Cell
                };
            }
            "METADATA" => {
                let names = c.metadata();
                if !names.is_empty()
                    && let Some(s) = last
                {
                    let list = if s == Section::Point {
                        &mut point_data
                    } else {
                        &mut cell_data
                    };
                    if let Some(a) = list.last_mut()
                        && a.components == names.len()
                    {
                        a.component_names = names;
                    }
                }
            }
            "FIELD" => {
                let n = number(&c, at, "FIELD", w.clone().nth(1))?;
                for k in 0..n {
                    let (fat, fl) = c.line().ok_or_else(|| {
                        c.err(
                            c.pos,
                            "FIELD",
                            format!("ends after {k} of {n} arrays (truncated file?)"),
                        )
                    })?;
                    let mut fw = fl.split_whitespace();
                    let name = unescape(fw.next().unwrap_or(""));
                    if name == "NULL_ARRAY" {
                        continue;
                    }
                    if name == "METADATA" {
                        c.metadata();
                        continue;
                    }
                    let what = format!("FIELD array \"{name}\"");
                    let comps = number(&c, fat, &what, fw.next())?;
                    let tuples = number(&c, fat, &what, fw.next())?;
                    let s = type_of(&c, fat, &what, fw.next())?;
                    let v = c.floats(
                        comps
                            .checked_mul(tuples)
                            .ok_or_else(|| c.err(fat, &what, "size overflows"))?,
                        s,
                        &what,
                    )?;
                    if section == Section::None {
                        continue;
                    }
                    if tuples != count {
                        return Err(c.err(
                            fat,
                            &what,
                            format!(
                                "has {tuples} tuples, but the {} section has {count}",
                                if section == Section::Point {
                                    "POINT_DATA"
                                } else {
                                    "CELL_DATA"
                                }
                            ),
                        ));
                    }
                    if comps == 0 {
                        continue;
                    }
                    push(
                        &c,
                        fat,
                        section,
                        &mut point_data,
                        &mut cell_data,
                        name,
                        s,
                        comps,
                        v,
                    )?;
                    last = Some(section);
                }
            }
            "SCALARS"
            | "VECTORS"
            | "NORMALS"
            | "TENSORS"
            | "TENSORS6"
            | "TEXTURE_COORDINATES"
            | "COLOR_SCALARS"
            | "LOOKUP_TABLE" => {
                if section == Section::None {
                    return Err(c.err(at, &key, "comes before POINT_DATA or CELL_DATA"));
                }
                let name = unescape(w.next().unwrap_or(""));
                let what = format!("{key} \"{name}\"");
                if key == "LOOKUP_TABLE" {
                    // A table definition: size RGBA entries (floats, or bytes in binary files).
                    let n = number(&c, at, &what, w.next())?;
                    let s = if c.binary {
                        Scalar::UInt8
                    } else {
                        Scalar::Float64
                    };
                    let size = n
                        .checked_mul(4)
                        .ok_or_else(|| c.err(at, &what, "size overflows"))?;
                    c.floats(size, s, &what)?;
                    continue;
                }
                let (s, comps) = match key.as_str() {
                    "SCALARS" => {
                        let s = type_of(&c, at, &what, w.next())?;
                        let comps = match w.next() {
                            None => 1,
                            Some(n) => n
                                .parse::<usize>()
                                .ok()
                                .filter(|&n| (1..=4).contains(&n))
                                .ok_or_else(|| {
                                    c.err(at, &what, format!("component count '{n}' is not 1 to 4"))
                                })?,
                        };
                        if c.peek_word().eq_ignore_ascii_case("LOOKUP_TABLE") {
                            c.line();
                        }
                        (s, comps)
                    }
                    "COLOR_SCALARS" => {
                        let comps = number(&c, at, &what, w.next())?;
                        let s = if c.binary {
                            Scalar::UInt8
                        } else {
                            Scalar::Float64
                        };
                        (s, comps.max(1))
                    }
                    "TEXTURE_COORDINATES" => {
                        let comps = number(&c, at, &what, w.next())?;
                        (type_of(&c, at, &what, w.next())?, comps.max(1))
                    }
                    "TENSORS" => (type_of(&c, at, &what, w.next())?, 9),
                    "TENSORS6" => (type_of(&c, at, &what, w.next())?, 6),
                    _ => (type_of(&c, at, &what, w.next())?, 3),
                };
                let n = count
                    .checked_mul(comps)
                    .ok_or_else(|| c.err(at, &what, "size overflows"))?;
                let v = c.floats(n, s, &what)?;
                push(
                    &c,
                    at,
                    section,
                    &mut point_data,
                    &mut cell_data,
                    name,
                    s,
                    comps,
                    v,
                )?;
                last = Some(section);
            }
            other => {
                return Err(c.err(
                    at,
                    "",
                    format!("unknown keyword '{other}' (a bad count before it?)"),
                ));
            }
        }
    }

    // Assemble and check.
    let (coords, points_type) = points.ok_or_else(|| Error::input(path, "POINTS", "missing"))?;
    let np = coords.len() / 3;
    if np > u32::MAX as usize {
        return Err(Error::input(
            path,
            "POINTS",
            format!("{np} points is more than fosls handles (2^32)"),
        ));
    }
    let mut file = VtuFile::from_cells(path, Vec::with_capacity(np), &[]);
    for (k, x) in coords.chunks_exact(3).enumerate() {
        if !x.iter().all(|v| v.is_finite()) {
            return Err(Error::input(
                path,
                "POINTS",
                format!(
                    "point {k} has a non-finite coordinate ({}, {}, {})",
                    x[0], x[1], x[2]
                ),
            ));
        }
        file.points.push([x[0], x[1], x[2]]);
    }
    let (offsets, connectivity) = (
        offsets.unwrap_or_default(),
        connectivity.unwrap_or_default(),
    );
    let types = match types {
        Some(t) => t,
        None if offsets.is_empty() => Vec::new(),
        None => {
            return Err(Error::input(
                path,
                "CELL_TYPES",
                "missing (the file has CELLS)",
            ));
        }
    };
    if types.len() != offsets.len() {
        return Err(Error::input(
            path,
            "CELL_TYPES",
            format!("has {} types for {} cells", types.len(), offsets.len()),
        ));
    }
    let cells_place = format!("CELLS ({})", c.at(cells_at));
    let cells_err = |problem: String| Error::input(path, &cells_place, problem);
    let mut prev = 0i64;
    for (cell, (&o, &t)) in offsets.iter().zip(&types).enumerate() {
        if o < prev || o as usize > connectivity.len() {
            return Err(cells_err(format!(
                "offset {o} of cell {cell} is out of order or past the connectivity ({} entries)",
                connectivity.len()
            )));
        }
        let known = u8::try_from(t).ok().map(cell_type::fixed_nodes);
        if known.is_none() || known == Some(Some(0)) {
            return Err(Error::input(
                path,
                "CELL_TYPES",
                format!(
                    "cell {cell} has unsupported VTK cell type {t} ({}); fosls reads vertices (1), \
                     lines (3), triangles (5), polygons of 3 or 4 vertices (7), pixels (8), quads \
                     (9), quadratic edges (21), triangles (22) and quads (23, 28), and Lagrange \
                     curves, triangles and quadrilaterals (68, 69, 70)",
                    cell_type::name(u8::try_from(t).unwrap_or(0))
                ),
            ));
        }
        let nodes = (o - prev) as usize;
        if let Some(Some(expect)) = known
            && nodes != expect
        {
            return Err(cells_err(format!(
                "cell {cell} ({}) has {nodes} nodes, expected {expect}",
                cell_type::name(t as u8)
            )));
        }
        if nodes == 0 {
            return Err(cells_err(format!("cell {cell} has no nodes")));
        }
        file.types.push(t as u8);
        file.offsets.push(o as usize);
        prev = o;
    }
    for (k, &v) in connectivity.iter().enumerate() {
        if v < 0 || v as usize >= np {
            return Err(cells_err(format!(
                "entry {k} of the connectivity refers to point {v}, but the file has {np} points"
            )));
        }
    }
    file.connectivity = connectivity.iter().map(|&v| v as u32).collect();
    let nc = file.cell_count();
    for (list, n, what) in [
        (&point_data, np, "POINT_DATA"),
        (&cell_data, nc, "CELL_DATA"),
    ] {
        if let Some(a) = list.first()
            && a.tuples() != n
        {
            return Err(Error::input(
                path,
                what,
                format!(
                    "has {} tuples, but the file has {n} {}",
                    a.tuples(),
                    if what == "POINT_DATA" {
                        "points"
                    } else {
                        "cells"
                    }
                ),
            ));
        }
    }
    file.point_data = point_data;
    file.cell_data = cell_data;
    file.point_components = 3;
    let mode = if c.binary { "BINARY" } else { "ASCII" };
    file.format = FileFormat {
        data_formats: vec![format!("legacy {}", mode.to_ascii_lowercase())],
        compressor: "none".into(),
        header_type: "-".into(),
        byte_order: if c.binary { "BigEndian" } else { "-" }.into(),
        pieces: 1,
        points_type: points_type.name().into(),
        container: format!("legacy VTK {version} {mode}"),
    };
    Ok(file)
}

/// Adds an array to its section; names must be unique in a section.
#[allow(clippy::too_many_arguments)]
fn push(
    c: &Cursor,
    at: usize,
    section: Section,
    point_data: &mut Vec<DataArray>,
    cell_data: &mut Vec<DataArray>,
    name: String,
    s: Scalar,
    components: usize,
    values: Vec<f64>,
) -> Result<()> {
    let list = if section == Section::Point {
        point_data
    } else {
        cell_data
    };
    if list.iter().any(|a| a.name == name) {
        return Err(c.err(
            at,
            &format!("array \"{name}\""),
            "appears twice in its section",
        ));
    }
    list.push(DataArray {
        name,
        scalar: s,
        components,
        component_names: Vec::new(),
        values,
    });
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<VtuFile> {
        parse_legacy(Path::new("t.vtk"), text.as_bytes(), &Budget::global())
    }

    const V42: &str = "# vtk DataFile Version 4.2
title
ASCII
DATASET UNSTRUCTURED_GRID
FIELD FieldData 1
TIME 1 1 double
0
POINTS 4 double
0 0 0 1 0 0 0 1 0
1 1 0
METADATA
INFORMATION 0

CELLS 3 11
3 0 1 2 3 1 3 2
2 0 1
CELL_TYPES 3
5 5 3
POINT_DATA 4
SCALARS p float 1
LOOKUP_TABLE default
1 2 3 4
VECTORS u double
0 0 0 1 0 0 0 1 0 1 1 0
METADATA
COMPONENT_NAMES
u_x
u_y
u_z

CELL_DATA 3
FIELD FieldData 1
tag 1 3 int
0 0 7
TENSORS s float
1 0 0 0 1 0 0 0 0
1 0 0 0 1 0 0 0 0
0 0 0 0 0 0 0 0 0
";

    #[test]
    fn reads_ascii_4_2() {
        let f = parse(V42).unwrap();
        assert_eq!(f.points.len(), 4);
        assert_eq!(f.types, vec![5, 5, 3]);
        assert_eq!(f.cell(1), &[1, 3, 2]);
        assert_eq!(f.cell(2), &[0, 1]);
        assert_eq!(f.point_data[0].name, "p");
        assert_eq!(f.point_data[1].components, 3);
        assert_eq!(f.point_data[1].component_names, vec!["u_x", "u_y", "u_z"]);
        assert_eq!(f.cell_data[0].values, vec![0.0, 0.0, 7.0]);
        assert_eq!(f.cell_data[1].components, 9);
        assert_eq!(f.format.container, "legacy VTK 4.2 ASCII");
    }

    #[test]
    fn reads_ascii_5_1_offsets() {
        let text = V42.replace("4.2", "5.1").replace(
            "CELLS 3 11\n3 0 1 2 3 1 3 2\n2 0 1\n",
            "CELLS 4 8\nOFFSETS vtktypeint64\n0 3 6 8\nCONNECTIVITY vtktypeint64\n0 1 2 1 3 2 0 1\n",
        );
        let f = parse(&text).unwrap();
        assert_eq!(f.cell(1), &[1, 3, 2]);
        assert_eq!(f.cell(2), &[0, 1]);
    }

    #[test]
    fn reads_binary() {
        let mut b: Vec<u8> =
            b"# vtk DataFile Version 3.0\nt\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 3 float\n"
                .to_vec();
        for v in [0f32, 0., 0., 1., 0., 0., 0., 1., 0.] {
            b.extend_from_slice(&v.to_be_bytes());
        }
        b.extend_from_slice(b"\nCELLS 1 4\n");
        for v in [3i32, 0, 1, 2] {
            b.extend_from_slice(&v.to_be_bytes());
        }
        b.extend_from_slice(b"\nCELL_TYPES 1\n");
        b.extend_from_slice(&5i32.to_be_bytes());
        b.extend_from_slice(b"\nPOINT_DATA 3\nSCALARS p double\nLOOKUP_TABLE default\n");
        for v in [1f64, 2., 3.] {
            b.extend_from_slice(&v.to_be_bytes());
        }
        b.push(b'\n');
        let f = parse_legacy(Path::new("b.vtk"), &b, &Budget::global()).unwrap();
        assert_eq!(f.points[1], [1.0, 0.0, 0.0]);
        assert_eq!(f.cell(0), &[0, 1, 2]);
        assert_eq!(f.point_data[0].values, vec![1.0, 2.0, 3.0]);
        // Truncated in the point data.
        let cut = &b[..b.len() - 9];
        let e = parse_legacy(Path::new("b.vtk"), cut, &Budget::global())
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("b.vtk: SCALARS \"p\" (byte "), "{e}");
        assert!(
            e.ends_with(
                "needs 24 bytes of Float64 data but the file has 16 left (truncated file?)"
            ),
            "{e}"
        );
    }

    #[test]
    fn bad_input_is_one_line() {
        let e = parse(&V42.replace("CELLS 3 11", "CELLS 3 12"))
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "t.vtk: CELLS (line 17): value 11 'CELL_TYPES' is not an integer"
        );
        let e = parse(&V42.replace("CELLS 3 11", "CELLS 3 10"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("t.vtk: CELLS (line 14): "), "{e}");
        let e = parse(&V42.replace("POINTS 4 double", "POINTS 5 double"))
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "t.vtk: POINTS (line 11): value 12 'METADATA' is not a number"
        );
        let e = parse(&V42[..V42.find("VECTORS u double").unwrap() + 25])
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "t.vtk: VECTORS \"u\" (line 24): declares 12 values but only 8 bytes are left (truncated file?)"
        );
        let e = parse("hello").unwrap_err().to_string();
        assert_eq!(
            e,
            "t.vtk: line 1: is not a legacy VTK header ('# vtk DataFile Version x.x')"
        );
        let e = parse(&V42.replace("UNSTRUCTURED_GRID", "POLYDATA"))
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "t.vtk: DATASET (line 4): is POLYDATA; fosls reads DATASET UNSTRUCTURED_GRID"
        );
        let e = parse(&V42.replace("5 5 3", "5 5 2 3"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("t.vtk: line 18: unknown keyword"), "{e}");
    }

    #[test]
    fn names_are_unescaped() {
        assert_eq!(unescape("von%20Mises"), "von Mises");
        assert_eq!(unescape("a%2"), "a%2");
    }
}
