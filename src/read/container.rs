//! Opening a solution in any container fosls reads (docs/design.md §4.2): VTU (`.vtu`), parallel
//! VTU (`.pvtu`, [`super::pvtu`]), ParaView collections (`.pvd`, [`super::pvd`]), legacy VTK
//! (`.vtk`, [`super::legacy`]) and XDMF 3 (`.xdmf`, [`super::xdmf`]). Every container gives the
//! same [`VtuFile`]; [`FileFormat::container`](super::vtu::FileFormat) says what was read.
//!
//! VTK's bookkeeping arrays are understood here, for every container: cells whose
//! `vtkGhostType` has the DUPLICATECELL bit (1) are dropped, with the points only they used;
//! ghost points (DUPLICATEPOINT) used by owned cells stay, and the mesh merges them with their
//! owner's copy in the other piece ([`crate::mesh`], via `piece_points`); `vtkGhostType`,
//! `vtkOriginalPointIds` and `vtkOriginalCellIds` are dropped, never taken for fields.

use std::path::{Path, PathBuf};

use quick_xml::events::Event;

use super::vtu::{self, DataArray, VtuFile};
use crate::error::{Error, Result};
use crate::limits::Budget;

/// Which time step of a collection (`.pvd`, XDMF time series) to read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StepChoice {
    /// The step with this index (0-based, in increasing time).
    Index(usize),
    /// The step whose time is closest to this one.
    Time(f64),
}

impl std::fmt::Display for StepChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StepChoice::Index(i) => write!(f, "--step {i}"),
            StepChoice::Time(t) => write!(f, "--time {t}"),
        }
    }
}

/// How to read a solution file.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ReadOptions {
    /// The time step of a collection; default: the last one.
    pub step: Option<StepChoice>,
}

/// The kinds of file fosls opens.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Container {
    Vtu,
    Pvtu,
    Pvd,
    Legacy,
    Xdmf,
}

impl Container {
    /// The container of `path`: from the extension (`.vtu`, `.pvtu`, `.pvd`, `.vtk`, `.xdmf` or
    /// `.xmf`, any case), else from the first bytes of the file; VTU when nothing else fits (the
    /// VTU reader then says what is wrong).
    pub fn of(path: &Path) -> Container {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase());
        let head = || {
            let mut head = vec![0u8; 4096];
            let n = std::fs::File::open(path)
                .and_then(|mut f| std::io::Read::read(&mut f, &mut head))
                .unwrap_or(0);
            head.truncate(n);
            head
        };
        match ext.as_deref() {
            Some("vtu") => Container::Vtu,
            Some("pvtu") => Container::Pvtu,
            Some("pvd") => Container::Pvd,
            // Some writers give XML VTK files the legacy extension.
            Some("vtk") => match head() {
                h if h.trim_ascii_start().starts_with(b"<") => Container::sniff(&h),
                _ => Container::Legacy,
            },
            Some("xdmf" | "xmf") => Container::Xdmf,
            _ => Container::sniff(&head()),
        }
    }

    /// The container of a file from its first bytes.
    pub fn sniff(head: &[u8]) -> Container {
        let has = |s: &[u8]| memchr::memmem::find(head, s).is_some();
        if head.trim_ascii_start().starts_with(b"# vtk DataFile") {
            Container::Legacy
        } else if has(b"<Xdmf") {
            Container::Xdmf
        } else if has(b"PUnstructuredGrid") {
            Container::Pvtu
        } else if has(b"\"Collection\"") || has(b"'Collection'") {
            Container::Pvd
        } else {
            Container::Vtu
        }
    }

    /// The name shown to users.
    pub fn name(self) -> &'static str {
        match self {
            Container::Vtu => "VTU",
            Container::Pvtu => "PVTU",
            Container::Pvd => "PVD",
            Container::Legacy => "legacy VTK",
            Container::Xdmf => "XDMF",
        }
    }
}

/// Reads the solution at `path` in whichever container it is ([`Container::of`]), with VTK's
/// ghost cells and bookkeeping arrays handled (module doc). `options.step` is for collections
/// (`.pvd`, XDMF); given for a single data set it is a usage error.
pub fn read_solution(path: &Path, options: &ReadOptions) -> Result<VtuFile> {
    let container = Container::of(path);
    if let Some(step) = options.step
        && !matches!(container, Container::Pvd | Container::Xdmf)
    {
        return Err(Error::Usage(format!(
            "{step}: {} is a single data set ({}); time steps are chosen in a .pvd collection \
             or an XDMF time series",
            path.display(),
            container.name()
        )));
    }
    match container {
        Container::Pvd => super::pvd::read_pvd(path, options.step),
        Container::Xdmf => super::xdmf::read_xdmf(path, options.step),
        other => read_dataset(path, other, &Budget::global()),
    }
}

/// Reads one data set that is no collection: VTU, PVTU or legacy VTK.
pub(crate) fn read_dataset(path: &Path, container: Container, budget: &Budget) -> Result<VtuFile> {
    match container {
        Container::Vtu => {
            let bytes = read_vtu_bytes(path)?;
            let mut file = vtu::parse_vtu_with(path, &bytes, budget)?;
            let notes = strip_bookkeeping(&mut file).notes();
            file.format.container = describe("VTU", &notes);
            Ok(file)
        }
        Container::Pvtu => super::pvtu::read_pvtu(path, budget),
        Container::Legacy => {
            let bytes = read_bytes(path)?;
            let mut file = super::legacy::parse_legacy(path, &bytes, budget)?;
            let notes = strip_bookkeeping(&mut file).notes();
            let kind = std::mem::take(&mut file.format.container);
            file.format.container = describe(&kind, &notes);
            Ok(file)
        }
        Container::Pvd | Container::Xdmf => Err(Error::input(
            path,
            "file",
            format!(
                "is a {} collection, which cannot be nested in another",
                container.name()
            ),
        )),
    }
}

/// "VTU" or "VTU (13 ghost cells dropped; …)".
pub(crate) fn describe(kind: &str, notes: &[String]) -> String {
    if notes.is_empty() {
        kind.to_string()
    } else {
        format!("{kind} ({})", notes.join("; "))
    }
}

/// The bytes of a VTU file, within the global memory cap, its start checked before the rest is
/// read (as [`vtu::read_vtu`] does).
pub(crate) fn read_vtu_bytes(path: &Path) -> Result<Vec<u8>> {
    crate::limits::read_bounded_checked(
        path,
        crate::limits::max_alloc(),
        "set FOSLS_MAX_ALLOC to raise it",
        vtu::check_start,
        |n| format!("is not a VTK XML file (no <VTKFile> element in its first {n} bytes)"),
    )
}

/// The bytes of `path`, within the global memory cap.
pub(crate) fn read_bytes(path: &Path) -> Result<Vec<u8>> {
    crate::limits::read_bounded(
        path,
        crate::limits::max_alloc(),
        "set FOSLS_MAX_ALLOC to raise it",
    )
}

/// A path named inside `container_file` (a piece, a data set, an HDF5 file): relative paths are
/// relative to the directory of `container_file`.
pub(crate) fn relative_to(container_file: &Path, name: &str) -> PathBuf {
    let p = Path::new(name);
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        container_file.parent().unwrap_or(Path::new("")).join(p)
    }
}

/// VTK's ghost-type bits (vtkDataSetAttributes): a cell or point owned by another piece.
const DUPLICATE: i64 = 1;

/// The bookkeeping arrays VTK writers add that are no fields.
const BOOKKEEPING: [&str; 3] = ["vtkGhostType", "vtkOriginalPointIds", "vtkOriginalCellIds"];

/// What [`strip_bookkeeping`] did.
#[derive(Clone, Debug, Default)]
pub(crate) struct Stripped {
    pub ghost_cells: usize,
    pub unused_points: usize,
    /// The bookkeeping arrays found (and dropped).
    pub ignored: Vec<String>,
}

impl Stripped {
    /// Adds what was done to another piece.
    pub fn add(&mut self, other: Stripped) {
        self.ghost_cells += other.ghost_cells;
        self.unused_points += other.unused_points;
        for name in other.ignored {
            if !self.ignored.contains(&name) {
                self.ignored.push(name);
            }
        }
    }

    /// One note per kind, for [`FileFormat::container`](super::vtu::FileFormat).
    pub fn notes(&self) -> Vec<String> {
        let mut notes = Vec::new();
        if self.ghost_cells > 0 {
            let mut s = format!(
                "{} ghost cell{} dropped",
                self.ghost_cells,
                plural(self.ghost_cells)
            );
            if self.unused_points > 0 {
                s.push_str(&format!(
                    ", and {} point{} used by ghost cells only",
                    self.unused_points,
                    plural(self.unused_points)
                ));
            }
            notes.push(s);
        }
        if !self.ignored.is_empty() {
            notes.push(format!("{} ignored", self.ignored.join(", ")));
        }
        notes
    }
}

/// Drops ghost cells (`vtkGhostType` & 1), the points only they used, and VTK's bookkeeping
/// arrays.
pub(crate) fn strip_bookkeeping(file: &mut VtuFile) -> Stripped {
    let mut done = Stripped::default();
    let ghost = file
        .cell_data
        .iter()
        .find(|a| a.name == "vtkGhostType" && a.components == 1)
        .map(|a| {
            a.values
                .iter()
                .map(|&v| (v as i64) & DUPLICATE != 0)
                .collect::<Vec<bool>>()
        });
    if let Some(ghost) = ghost
        && ghost.iter().any(|&g| g)
    {
        let keep: Vec<usize> = (0..file.cell_count()).filter(|&c| !ghost[c]).collect();
        done.ghost_cells = file.cell_count() - keep.len();
        keep_cells(file, &keep);
        done.unused_points = drop_unused_points(file);
    }
    for arrays in [&mut file.point_data, &mut file.cell_data] {
        arrays.retain(|a| {
            let bookkeeping = BOOKKEEPING.contains(&a.name.as_str());
            if bookkeeping && !done.ignored.contains(&a.name) {
                done.ignored.push(a.name.clone());
            }
            !bookkeeping
        });
    }
    done
}

fn plural(n: usize) -> &'static str {
    if n == 1 { "" } else { "s" }
}

/// Keeps the cells `keep` (increasing), with their cell data.
fn keep_cells(file: &mut VtuFile, keep: &[usize]) {
    let mut types = Vec::with_capacity(keep.len());
    let mut offsets = vec![0];
    let mut connectivity = Vec::new();
    for &c in keep {
        types.push(file.types[c]);
        connectivity.extend_from_slice(file.cell(c));
        offsets.push(connectivity.len());
    }
    for a in &mut file.cell_data {
        let n = a.components;
        a.values = keep
            .iter()
            .flat_map(|&c| a.values[c * n..(c + 1) * n].iter().copied())
            .collect();
    }
    file.types = types;
    file.offsets = offsets;
    file.connectivity = connectivity;
}

/// Removes the points no cell uses, with their point data (piece starts renumbered); returns
/// how many.
fn drop_unused_points(file: &mut VtuFile) -> usize {
    let np = file.points.len();
    let mut used = vec![false; np];
    for &v in &file.connectivity {
        used[v as usize] = true;
    }
    let kept = used.iter().filter(|&&u| u).count();
    if kept == np {
        return 0;
    }
    let mut new_index = vec![u32::MAX; np];
    let mut next = 0u32;
    for i in 0..np {
        if used[i] {
            new_index[i] = next;
            next += 1;
        }
    }
    for v in &mut file.connectivity {
        *v = new_index[*v as usize];
    }
    // A piece starts at the first kept point at or after its old start.
    let before: Vec<usize> = std::iter::once(0)
        .chain(used.iter().scan(0usize, |s, &u| {
            *s += u as usize;
            Some(*s)
        }))
        .collect();
    for p in &mut file.piece_points {
        *p = before[*p];
    }
    file.points = (0..np)
        .filter(|&i| used[i])
        .map(|i| file.points[i])
        .collect();
    for a in &mut file.point_data {
        let n = a.components;
        a.values = (0..np)
            .filter(|&i| used[i])
            .flat_map(|i| a.values[i * n..(i + 1) * n].iter().copied())
            .collect();
    }
    np - kept
}

/// An array a container declares: name and component count.
pub(crate) type Declared = (String, usize);

/// Joins data sets read from separate files (the pieces of a `.pvtu`, the parts of a `.pvd`
/// step) into one file of several pieces: points and cells concatenated, piece starts kept so
/// that the mesh merges the points the pieces share. `arrays` (point, cell) names the arrays
/// to keep, each required in every part with the same component count (`origin` says where
/// they were declared, for messages); `None` keeps the arrays of the first part and requires
/// them in the others.
pub(crate) fn concat(
    path: &Path,
    parts: Vec<(PathBuf, VtuFile)>,
    arrays: Option<(&[Declared], &[Declared])>,
    origin: &str,
) -> Result<VtuFile> {
    let first = &parts[0].1;
    let declared = |list: &[DataArray]| -> Vec<Declared> {
        list.iter()
            .map(|a| (a.name.clone(), a.components))
            .collect()
    };
    let (point_names, cell_names) = match arrays {
        Some((p, c)) => (p.to_vec(), c.to_vec()),
        None => (declared(&first.point_data), declared(&first.cell_data)),
    };
    let total: usize = parts.iter().map(|(_, f)| f.points.len()).sum();
    if total > u32::MAX as usize {
        return Err(Error::input(
            path,
            "pieces",
            format!("{total} points is more than fosls handles (2^32)"),
        ));
    }
    let mut out = VtuFile::from_cells(path, Vec::with_capacity(total), &[]);
    out.piece_points.clear();
    out.point_components = 2;
    let pick = |part: &Path,
                list: &[DataArray],
                name: &str,
                components: usize,
                kind: &str|
     -> Result<DataArray> {
        let a = list.iter().find(|a| a.name == name).ok_or_else(|| {
            Error::input(
                part,
                format!("{kind} array \"{name}\""),
                format!("is missing ({origin} has it)"),
            )
        })?;
        if a.components != components {
            return Err(Error::input(
                part,
                format!("{kind} array \"{name}\""),
                format!("has {} components, {components} in {origin}", a.components),
            ));
        }
        Ok(a.clone())
    };
    let mut point_data: Vec<DataArray> = Vec::new();
    let mut cell_data: Vec<DataArray> = Vec::new();
    for (k, (part, f)) in parts.iter().enumerate() {
        let base = out.points.len();
        out.piece_points
            .extend(f.piece_points.iter().map(|&p| p + base));
        out.points.extend_from_slice(&f.points);
        out.point_components = out.point_components.max(f.point_components);
        let conn_base = out.connectivity.len();
        out.connectivity
            .extend(f.connectivity.iter().map(|&v| v + base as u32));
        out.offsets
            .extend(f.offsets[1..].iter().map(|&o| o + conn_base));
        out.types.extend_from_slice(&f.types);
        for (names, list, merged, kind) in [
            (&point_names, &f.point_data, &mut point_data, "point"),
            (&cell_names, &f.cell_data, &mut cell_data, "cell"),
        ] {
            for (i, (name, components)) in names.iter().enumerate() {
                let a = pick(part, list, name, *components, kind)?;
                if k == 0 {
                    merged.push(a);
                } else {
                    merged[i].values.extend_from_slice(&a.values);
                }
            }
        }
        let fmt = &f.format;
        for d in &fmt.data_formats {
            if !out.format.data_formats.contains(d) {
                out.format.data_formats.push(d.clone());
            }
        }
        if k == 0 {
            out.format.compressor = fmt.compressor.clone();
            out.format.header_type = fmt.header_type.clone();
            out.format.byte_order = fmt.byte_order.clone();
            out.format.points_type = fmt.points_type.clone();
        }
        out.format.pieces += fmt.pieces.max(1);
    }
    if out.piece_points.is_empty() {
        out.piece_points.push(0);
    }
    out.point_data = point_data;
    out.cell_data = cell_data;
    Ok(out)
}

/// An XML element of a small file (`.pvtu`, `.pvd`, `.xdmf`): name, attributes, children and
/// text, with the byte where it starts (for messages).
#[derive(Clone, Debug, Default)]
pub(crate) struct Element {
    pub name: String,
    pub attrs: Vec<(String, String)>,
    pub children: Vec<Element>,
    pub text: String,
    pub byte: u64,
}

impl Element {
    pub fn attr(&self, key: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// The children named `name`.
    pub fn children_named<'a>(&'a self, name: &'a str) -> impl Iterator<Item = &'a Element> {
        self.children.iter().filter(move |c| c.name == name)
    }

    pub fn child(&self, name: &str) -> Option<&Element> {
        self.children.iter().find(|c| c.name == name)
    }
}

/// Parses a small XML file into its root [`Element`]; one-line errors naming the byte.
pub(crate) fn parse_xml(path: &Path, bytes: &[u8]) -> Result<Element> {
    let err = |place: &str, problem: String| Error::input(path, place, problem);
    if bytes.iter().all(u8::is_ascii_whitespace) {
        return Err(err("file", "is empty".into()));
    }
    let mut reader = quick_xml::Reader::from_reader(bytes);
    let mut stack: Vec<Element> = Vec::new();
    let mut root: Option<Element> = None;
    loop {
        let pos = reader.buffer_position();
        let event = reader.read_event().map_err(|e| {
            let at = reader.error_position();
            let end = bytes.trim_ascii_end().len() as u64;
            let eof = e.to_string().contains("end of input");
            err(
                &format!("byte {at}"),
                format!(
                    "not well-formed XML ({e}){}",
                    if eof || at + 1 >= end {
                        " (truncated file?)"
                    } else {
                        ""
                    }
                ),
            )
        })?;
        let (start, empty) = match &event {
            Event::Start(e) => (Some(e), false),
            Event::Empty(e) => (Some(e), true),
            _ => (None, false),
        };
        if let Some(e) = start {
            if root.is_some() && stack.is_empty() {
                return Err(err(&format!("byte {pos}"), "a second root element".into()));
            }
            let qname = e.name();
            let name: &str = qname.as_ref();
            let mut el = Element {
                name: name.to_string(),
                byte: pos,
                ..Element::default()
            };
            for a in e.attributes() {
                let a = a.map_err(|x| {
                    err(
                        &format!("<{name}> at byte {pos}"),
                        format!("malformed attribute ({x})"),
                    )
                })?;
                let key: &str = a.key.as_ref();
                let value = a
                    .normalized_value(quick_xml::XmlVersion::Implicit1_0)
                    .map_err(|x| {
                        err(
                            &format!("<{name}> at byte {pos}"),
                            format!("malformed attribute {key} ({x})"),
                        )
                    })?;
                el.attrs.push((key.to_string(), value.into_owned()));
            }
            if empty {
                match stack.last_mut() {
                    Some(parent) => parent.children.push(el),
                    None => root = Some(el),
                }
            } else {
                stack.push(el);
            }
            continue;
        }
        match event {
            Event::Text(t) => {
                if let Some(top) = stack.last_mut() {
                    top.text.push_str(&t.into_inner());
                }
            }
            Event::CData(t) => {
                if let Some(top) = stack.last_mut() {
                    top.text.push_str(&t.into_inner());
                }
            }
            Event::GeneralRef(r) => {
                if let Some(top) = stack.last_mut() {
                    let name: &str = r.as_ref();
                    let c = match name {
                        "amp" => Some('&'),
                        "lt" => Some('<'),
                        "gt" => Some('>'),
                        "quot" => Some('"'),
                        "apos" => Some('\''),
                        n => n
                            .strip_prefix("#x")
                            .and_then(|h| u32::from_str_radix(h, 16).ok())
                            .or_else(|| n.strip_prefix('#').and_then(|d| d.parse().ok()))
                            .and_then(char::from_u32),
                    };
                    let c = c.ok_or_else(|| {
                        err(&format!("byte {pos}"), format!("unknown entity &{name};"))
                    })?;
                    top.text.push(c);
                }
            }
            Event::End(_) => {
                let Some(el) = stack.pop() else {
                    return Err(err(&format!("byte {pos}"), "unexpected end tag".into()));
                };
                match stack.last_mut() {
                    Some(parent) => parent.children.push(el),
                    None => root = Some(el),
                }
            }
            Event::Eof => break,
            _ => {}
        }
    }
    if let Some(open) = stack.last() {
        return Err(err(
            "file",
            format!("ends inside <{}> (truncated file?)", open.name),
        ));
    }
    root.ok_or_else(|| err("file", "is not an XML file (no root element)".into()))
}

/// The index of the chosen step among `times` (sorted increasing, distinct): the last by
/// default, `Index(i)` the i-th, `Time(t)` the closest (the earlier one on a tie).
pub(crate) fn choose_step(path: &Path, times: &[f64], choice: Option<StepChoice>) -> Result<usize> {
    let list = || {
        let mut s = times
            .iter()
            .take(8)
            .map(|t| t.to_string())
            .collect::<Vec<_>>()
            .join(", ");
        if times.len() > 8 {
            s.push_str(&format!(", … ({} in all)", times.len()));
        }
        s
    };
    match choice {
        None => Ok(times.len() - 1),
        Some(StepChoice::Index(i)) if i < times.len() => Ok(i),
        Some(c @ StepChoice::Index(_)) => Err(Error::input(
            path,
            c,
            format!(
                "the collection has {} time step{} (--step 0 to {}; t = {})",
                times.len(),
                plural(times.len()),
                times.len() - 1,
                list()
            ),
        )),
        Some(StepChoice::Time(t)) if t.is_finite() => {
            let mut best = 0;
            for (i, &s) in times.iter().enumerate() {
                if (s - t).abs() < (times[best] - t).abs() {
                    best = i;
                }
            }
            Ok(best)
        }
        Some(c) => Err(Error::Usage(format!("{c}: not a finite time"))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sniffs_containers() {
        assert_eq!(
            Container::sniff(b"# vtk DataFile Version 4.2\n"),
            Container::Legacy
        );
        assert_eq!(
            Container::sniff(b"<?xml version=\"1.0\"?>\n<Xdmf Version=\"3.0\">"),
            Container::Xdmf
        );
        assert_eq!(
            Container::sniff(b"<VTKFile type=\"PUnstructuredGrid\">"),
            Container::Pvtu
        );
        assert_eq!(
            Container::sniff(b"<VTKFile type=\"Collection\">"),
            Container::Pvd
        );
        assert_eq!(Container::sniff(b"<VTKFile>"), Container::Vtu);
        assert_eq!(Container::of(Path::new("a/b.PVTU")), Container::Pvtu);
    }

    #[test]
    fn steps_are_chosen_by_index_or_closest_time() {
        let p = Path::new("c.pvd");
        let t = [0.0, 0.5, 1.0];
        assert_eq!(choose_step(p, &t, None).unwrap(), 2);
        assert_eq!(choose_step(p, &t, Some(StepChoice::Index(0))).unwrap(), 0);
        assert_eq!(choose_step(p, &t, Some(StepChoice::Time(0.7))).unwrap(), 1);
        assert_eq!(choose_step(p, &t, Some(StepChoice::Time(0.75))).unwrap(), 1);
        assert_eq!(choose_step(p, &t, Some(StepChoice::Time(9.0))).unwrap(), 2);
        let e = choose_step(p, &t, Some(StepChoice::Index(3)))
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "c.pvd: --step 3: the collection has 3 time steps (--step 0 to 2; t = 0, 0.5, 1)"
        );
    }

    #[test]
    fn ghost_cells_and_bookkeeping_arrays_are_dropped() {
        use crate::read::decode::Scalar;
        let mut f = VtuFile::from_cells(
            Path::new("g.vtu"),
            vec![
                [0., 0., 0.],
                [1., 0., 0.],
                [0., 1., 0.],
                [1., 1., 0.],
                [2., 1., 0.],
            ],
            &[(5, vec![0, 1, 2]), (5, vec![1, 3, 2]), (5, vec![1, 4, 3])],
        );
        let arr = |name: &str, values: Vec<f64>| DataArray {
            name: name.into(),
            scalar: Scalar::UInt8,
            components: 1,
            component_names: Vec::new(),
            values,
        };
        f.cell_data.push(arr("vtkGhostType", vec![0., 0., 1.]));
        f.cell_data
            .push(arr("vtkOriginalCellIds", vec![0., 1., 2.]));
        f.cell_data.push(arr("tag", vec![7., 8., 9.]));
        f.point_data
            .push(arr("vtkGhostType", vec![0., 0., 0., 1., 1.]));
        f.point_data.push(arr("p", vec![0., 1., 2., 3., 4.]));
        let notes = strip_bookkeeping(&mut f).notes();
        assert_eq!(f.cell_count(), 2);
        assert_eq!(f.points.len(), 4);
        assert_eq!(f.cell(1), &[1, 3, 2]);
        assert_eq!(f.cell_data.len(), 1);
        assert_eq!(f.cell_data[0].values, vec![7., 8.]);
        assert_eq!(f.point_data.len(), 1);
        assert_eq!(f.point_data[0].values, vec![0., 1., 2., 3.]);
        assert_eq!(
            notes,
            vec![
                "1 ghost cell dropped, and 1 point used by ghost cells only".to_string(),
                "vtkGhostType, vtkOriginalCellIds ignored".to_string()
            ]
        );
    }

    #[test]
    fn xml_errors_are_one_line() {
        let p = Path::new("x.pvd");
        let e = parse_xml(p, b"<a><b>").unwrap_err().to_string();
        assert_eq!(e, "x.pvd: file: ends inside <b> (truncated file?)");
        let e = parse_xml(p, b"  ").unwrap_err().to_string();
        assert_eq!(e, "x.pvd: file: is empty");
        let r = parse_xml(p, b"<a k='1'><b>x &amp; y</b><c/></a>").unwrap();
        assert_eq!(r.attr("k"), Some("1"));
        assert_eq!(r.child("b").unwrap().text, "x & y");
        assert_eq!(r.children.len(), 2);
    }
}
