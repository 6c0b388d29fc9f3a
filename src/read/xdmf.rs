//! XDMF 3 (`.xdmf`) with heavy data in HDF5 or inline XML, as DOLFINx 0.11's `XDMFFile` writes
//! it (`write_mesh`, `write_meshtags`, `write_function`).
//!
//! - **The mesh** is the first `Uniform` grid with a `Topology` and a `Geometry` of its own, of
//!   a 2D cell type: `Triangle`, `Triangle_6`, `Quadrilateral`, `Quadrilateral_8`,
//!   `Quadrilateral_9`; geometry `XY`, `XYZ` or `X_Y_Z`.
//! - **Fields** are the `Attribute`s (`Center="Node"` → point data, `"Cell"` → cell data) of the
//!   grids on that mesh (its own, and those that `xi:include` its topology and geometry), in
//!   temporal collections by their `<Time Value>`: the last time unless [`StepChoice`] says
//!   otherwise.
//! - **Tags** (`write_meshtags`): a grid with its own `Edge`/`Edge_3`/`Polyline` topology on the
//!   mesh's geometry becomes boundary line cells with a cell array named after its attribute
//!   (e.g. `facet_tags`, usable as `[boundaries] tag_array`); a grid of 2D cells becomes a cell
//!   array on the mesh cells it names. Cells a tag array does not cover get 0.
//! - **Node order**: XDMF's is VTK's (vertices, then the mid nodes of edges 0–1, 1–2, 2–0 for
//!   `Triangle_6`), which DOLFINx 0.11 writes; a `Triangle_6` file whose mid nodes fit the other
//!   common order (the mid node opposite vertex 0, 1, 2) is permuted, decided on the geometry of
//!   all cells; quadrilaterals numbered as a tensor product (0, 1, 3, 2 counter-clockwise) too.
//!
//! HDF5 data (`Format="HDF"`, `file.h5:/path`) needs the `xdmf` cargo feature (the HDF5 C
//! library); without it such a file is refused with the command that builds it.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use super::cell_type;
use super::container::{self, Element, StepChoice};
use super::decode::Scalar;
use super::vtu::{DataArray, FileFormat, VtuFile};
use crate::error::{Error, Result};
use crate::limits::Budget;

/// The one line an `.xdmf` with HDF5 data gets from a build without the `xdmf` feature.
pub fn feature_message(path: &Path) -> String {
    format!(
        "{}: XDMF needs fosls built with --features xdmf (and libhdf5-dev): cargo build \
         --release --features xdmf",
        path.display()
    )
}

/// A DataItem's values, its dimensions and the type they had.
struct Item {
    values: Vec<f64>,
    dims: Vec<usize>,
    scalar: Scalar,
}

/// Heavy data: HDF5 files opened once each.
struct Heavy<'a> {
    xdmf: &'a Path,
    budget: Budget,
    #[cfg(feature = "xdmf")]
    files: HashMap<PathBuf, hdf5_metno::File>,
    #[cfg(not(feature = "xdmf"))]
    files: HashMap<PathBuf, ()>,
}

impl Heavy<'_> {
    fn err(&self, place: impl std::fmt::Display, problem: impl std::fmt::Display) -> Error {
        Error::input(self.xdmf, place, problem)
    }

    /// Reads a `<DataItem>`: inline XML numbers or an HDF5 dataset.
    fn item(&mut self, el: &Element, what: &str) -> Result<Item> {
        let place = format!("{what} <DataItem> (byte {})", el.byte);
        if el.attr("Reference").is_some() {
            return Err(self.err(
                &place,
                "DataItem references are not supported (fosls reads XDMF as DOLFINx writes it)",
            ));
        }
        if let Some(t) = el.attr("ItemType")
            && !t.eq_ignore_ascii_case("Uniform")
        {
            return Err(self.err(
                &place,
                format!("ItemType=\"{t}\" is not supported (only plain data items)"),
            ));
        }
        let dims: Vec<usize> = match el.attr("Dimensions") {
            None => Vec::new(),
            Some(d) => d
                .split_whitespace()
                .map(|w| w.parse::<usize>())
                .collect::<std::result::Result<_, _>>()
                .map_err(|_| self.err(&place, format!("Dimensions \"{d}\" are not integers")))?,
        };
        let precision = el.attr("Precision").unwrap_or("4").trim();
        let number = el
            .attr("NumberType")
            .or(el.attr("DataType"))
            .unwrap_or("Float");
        let declared = match (number.to_ascii_lowercase().as_str(), precision) {
            ("float", "8") => Scalar::Float64,
            ("float", _) => Scalar::Float32,
            ("int", "8") => Scalar::Int64,
            ("int", "2") => Scalar::Int16,
            ("int", "1") | ("char", _) => Scalar::Int8,
            ("int", _) => Scalar::Int32,
            ("uint", "8") => Scalar::UInt64,
            ("uint", "2") => Scalar::UInt16,
            ("uint", "1") | ("uchar", _) => Scalar::UInt8,
            ("uint", _) => Scalar::UInt32,
            (other, _) => {
                return Err(self.err(&place, format!("NumberType \"{other}\" is not supported")));
            }
        };
        let format = el.attr("Format").unwrap_or("XML");
        let item = match format.to_ascii_uppercase().as_str() {
            "XML" => {
                let n = el.text.len() / 2 + 1;
                self.budget
                    .reserve(n as u64 * 8, "the data item")
                    .map_err(|m| self.err(&place, m))?;
                let values = super::decode::parse_ascii::<f64>(el.text.as_bytes(), declared, None)
                    .map_err(|m| self.err(&place, m))?;
                Item {
                    values,
                    dims: dims.clone(),
                    scalar: declared,
                }
            }
            "HDF" => self.hdf(el.text.trim(), &place)?,
            other => {
                return Err(self.err(
                    &place,
                    format!("Format=\"{other}\" is not supported (XML or HDF)"),
                ));
            }
        };
        let expect: usize = dims.iter().product();
        if !dims.is_empty() && expect != item.values.len() {
            return Err(self.err(
                &place,
                format!(
                    "Dimensions \"{}\" need {expect} values, the data has {}",
                    el.attr("Dimensions").unwrap_or(""),
                    item.values.len()
                ),
            ));
        }
        Ok(Item {
            dims: if dims.is_empty() { item.dims } else { dims },
            ..item
        })
    }

    #[cfg(not(feature = "xdmf"))]
    fn hdf(&mut self, _spec: &str, _place: &str) -> Result<Item> {
        let _ = &self.files;
        Err(Error::Usage(feature_message(self.xdmf)))
    }

    #[cfg(feature = "xdmf")]
    fn hdf(&mut self, spec: &str, place: &str) -> Result<Item> {
        use hdf5_metno::types::TypeDescriptor;
        let Some((file, dataset)) = spec
            .rsplit_once(':')
            .filter(|(f, d)| !f.is_empty() && d.starts_with('/'))
        else {
            return Err(self.err(
                place,
                format!("\"{spec}\" is not an HDF5 reference file.h5:/path"),
            ));
        };
        let h5 = container::relative_to(self.xdmf, file);
        if !self.files.contains_key(&h5) {
            if !h5.is_file() {
                return Err(self.err(
                    place,
                    format!(
                        "{} does not exist (the HDF5 file of \"{spec}\")",
                        h5.display()
                    ),
                ));
            }
            let f = hdf5_metno::File::open(&h5).map_err(|e| {
                Error::input(&h5, "file", format!("is not a readable HDF5 file ({e})"))
            })?;
            self.files.insert(h5.clone(), f);
        }
        let f = &self.files[&h5];
        let h5err = |problem: String| Error::input(&h5, dataset, problem);
        let ds = f
            .dataset(dataset)
            .map_err(|e| h5err(format!("no such dataset ({e})")))?;
        let dims = ds.shape();
        let n: usize = dims.iter().product();
        self.budget
            .reserve(n as u64 * 8, "the dataset")
            .map_err(&h5err)?;
        let scalar = match ds.dtype().and_then(|t| t.to_descriptor()) {
            Ok(TypeDescriptor::Float(s)) if s as usize == 4 => Scalar::Float32,
            Ok(TypeDescriptor::Float(_)) => Scalar::Float64,
            Ok(TypeDescriptor::Integer(s)) => match s as usize {
                1 => Scalar::Int8,
                2 => Scalar::Int16,
                4 => Scalar::Int32,
                _ => Scalar::Int64,
            },
            Ok(TypeDescriptor::Unsigned(s)) => match s as usize {
                1 => Scalar::UInt8,
                2 => Scalar::UInt16,
                4 => Scalar::UInt32,
                _ => Scalar::UInt64,
            },
            Ok(other) => return Err(h5err(format!("has type {other}, not numbers"))),
            Err(e) => return Err(h5err(format!("unreadable type ({e})"))),
        };
        let values = ds
            .read_raw::<f64>()
            .map_err(|e| h5err(format!("cannot be read ({e})")))?;
        if values.len() != n {
            return Err(h5err(format!(
                "gave {} values for its shape {dims:?}",
                values.len()
            )));
        }
        Ok(Item {
            values,
            dims,
            scalar,
        })
    }
}

/// A Uniform grid and the time it belongs to.
struct Uniform<'a> {
    el: &'a Element,
    time: Option<f64>,
}

fn time_of(el: &Element) -> Option<std::result::Result<f64, String>> {
    let t = el.child("Time")?;
    let v = t.attr("Value")?;
    Some(
        v.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("<Time Value=\"{v}\"> is not a finite number")),
    )
}

fn collect<'a>(
    xdmf: &Path,
    el: &'a Element,
    time: Option<f64>,
    out: &mut Vec<Uniform<'a>>,
) -> Result<()> {
    for (k, g) in el.children_named("Grid").enumerate() {
        let own = match time_of(g) {
            None => time,
            Some(Ok(t)) => Some(t),
            Some(Err(m)) => {
                return Err(Error::input(
                    xdmf,
                    format!("<Grid> \"{}\"", g.attr("Name").unwrap_or(&k.to_string())),
                    m,
                ));
            }
        };
        match g.attr("GridType").unwrap_or("Uniform") {
            "Uniform" => out.push(Uniform { el: g, time: own }),
            "Collection" | "Tree" => collect(xdmf, g, own, out)?,
            other => {
                return Err(Error::input(
                    xdmf,
                    format!("<Grid> \"{}\"", g.attr("Name").unwrap_or("")),
                    format!("GridType=\"{other}\" is not supported (Uniform, Collection)"),
                ));
            }
        }
    }
    Ok(())
}

/// How a grid names its topology or geometry.
enum Part<'a> {
    Own(&'a Element),
    /// An `xi:include` of the mesh's.
    Mesh,
    None,
}

fn part<'a>(g: &'a Element, name: &str) -> Part<'a> {
    if let Some(e) = g.child(name) {
        return Part::Own(e);
    }
    let included = g.children_named("xi:include").any(|i| {
        i.attr("xpointer")
            .is_some_and(|x| x.contains(name) || x.ends_with("/*)"))
    });
    if included { Part::Mesh } else { Part::None }
}

/// XDMF topology types: VTK type and nodes per element.
fn topology_type(name: &str, nodes: Option<usize>) -> Option<(u8, usize)> {
    Some(match name.to_ascii_lowercase().as_str() {
        "triangle" => (cell_type::TRIANGLE, 3),
        "triangle_6" | "tri_6" => (cell_type::QUADRATIC_TRIANGLE, 6),
        "quadrilateral" => (cell_type::QUAD, 4),
        "quadrilateral_8" | "quad_8" => (cell_type::QUADRATIC_QUAD, 8),
        "quadrilateral_9" | "quad_9" => (cell_type::BIQUADRATIC_QUAD, 9),
        "edge" => (cell_type::LINE, 2),
        "edge_3" => (cell_type::QUADRATIC_EDGE, 3),
        "polyline" if nodes.unwrap_or(2) == 2 => (cell_type::LINE, 2),
        "polyline" if nodes == Some(3) => (cell_type::QUADRATIC_EDGE, 3),
        "polyvertex" => (cell_type::VERTEX, 1),
        _ => return None,
    })
}

fn is_2d(t: u8) -> bool {
    !matches!(
        t,
        cell_type::LINE | cell_type::QUADRATIC_EDGE | cell_type::VERTEX
    )
}

/// Cells of a topology: VTK type and node lists.
struct Cells {
    vtk: u8,
    nodes: usize,
    conn: Vec<u32>,
}

fn topology(h: &mut Heavy, el: &Element, what: &str, np: Option<usize>) -> Result<Cells> {
    let place = format!("{what} <Topology>");
    let name = el.attr("TopologyType").or(el.attr("Type")).unwrap_or("");
    let per = el
        .attr("NodesPerElement")
        .and_then(|n| n.trim().parse::<usize>().ok());
    let (vtk, nodes) = topology_type(name, per).ok_or_else(|| {
        h.err(
            &place,
            format!(
                "TopologyType \"{name}\" is not supported (Triangle, Triangle_6, Quadrilateral, \
                 Quadrilateral_8, Quadrilateral_9, Edge, Edge_3, Polyline; 3D cells are not \
                 supported yet)"
            ),
        )
    })?;
    if let Some(p) = per
        && p != nodes
    {
        return Err(h.err(
            &place,
            format!("NodesPerElement=\"{p}\" but a {name} has {nodes} nodes"),
        ));
    }
    let data = el
        .child("DataItem")
        .ok_or_else(|| h.err(&place, "has no <DataItem>"))?;
    let item = h.item(data, &place)?;
    if item.values.len() % nodes != 0 {
        return Err(h.err(
            &place,
            format!(
                "has {} node numbers, not a multiple of the {nodes} nodes of a {name}",
                item.values.len()
            ),
        ));
    }
    let n = item.values.len() / nodes;
    if let Some(declared) = el
        .attr("NumberOfElements")
        .and_then(|n| n.trim().parse::<usize>().ok())
        && declared != n
    {
        return Err(h.err(
            &place,
            format!("NumberOfElements=\"{declared}\" but the data holds {n} cells"),
        ));
    }
    let mut conn = Vec::with_capacity(item.values.len());
    for (k, &v) in item.values.iter().enumerate() {
        let ok = v >= 0.0 && v.fract() == 0.0 && np.is_none_or(|np| (v as usize) < np);
        if !ok {
            return Err(h.err(
                &place,
                format!(
                    "entry {k} (cell {}) is {v}, not a point index{}",
                    k / nodes,
                    np.map_or(String::new(), |np| format!(" below {np}"))
                ),
            ));
        }
        conn.push(v as u32);
    }
    Ok(Cells { vtk, nodes, conn })
}

fn geometry(h: &mut Heavy, el: &Element) -> Result<(Vec<[f64; 3]>, Scalar)> {
    let place = "mesh <Geometry>";
    let kind = el
        .attr("GeometryType")
        .or(el.attr("Type"))
        .unwrap_or("XYZ")
        .to_ascii_uppercase();
    let items: Vec<&Element> = el.children_named("DataItem").collect();
    let first = items
        .first()
        .ok_or_else(|| h.err(place, "has no <DataItem>"))?;
    let (points, scalar) = match kind.as_str() {
        "XY" | "XYZ" => {
            let d = if kind == "XY" { 2 } else { 3 };
            let item = h.item(first, place)?;
            if item.values.len() % d != 0 {
                return Err(h.err(
                    place,
                    format!(
                        "{kind} geometry with {} numbers, not a multiple of {d}",
                        item.values.len()
                    ),
                ));
            }
            let pts: Vec<[f64; 3]> = item
                .values
                .chunks_exact(d)
                .map(|c| [c[0], c[1], if d == 3 { c[2] } else { 0.0 }])
                .collect();
            (pts, item.scalar)
        }
        "X_Y_Z" | "X_Y" => {
            let mut cols = Vec::new();
            let mut scalar = Scalar::Float64;
            for it in &items {
                let item = h.item(it, place)?;
                scalar = item.scalar;
                cols.push(item.values);
            }
            if cols.len() < 2 || cols.iter().any(|c| c.len() != cols[0].len()) {
                return Err(h.err(
                    place,
                    format!("{kind} geometry needs one DataItem of equal length per coordinate"),
                ));
            }
            let pts: Vec<[f64; 3]> = (0..cols[0].len())
                .map(|i| [cols[0][i], cols[1][i], cols.get(2).map_or(0.0, |c| c[i])])
                .collect();
            (pts, scalar)
        }
        other => {
            return Err(h.err(
                place,
                format!("GeometryType \"{other}\" is not supported (XY, XYZ, X_Y_Z)"),
            ));
        }
    };
    for (k, p) in points.iter().enumerate() {
        if !p.iter().all(|v| v.is_finite()) {
            return Err(h.err(
                place,
                format!(
                    "point {k} has a non-finite coordinate ({}, {}, {})",
                    p[0], p[1], p[2]
                ),
            ));
        }
    }
    Ok((points, scalar))
}

/// Puts the mid nodes of `Triangle_6` cells and the vertices of quadrilaterals in VTK order
/// when the file's order fits the other convention better (module doc); returns a note.
fn fix_order(cells: &mut Cells, points: &[[f64; 3]]) -> Option<String> {
    let x = |i: u32| points[i as usize];
    let d = |a: [f64; 3], b: [f64; 3]| (a[0] - b[0]).hypot(a[1] - b[1]);
    let mid = |a: [f64; 3], b: [f64; 3]| [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0, 0.0];
    match cells.vtk {
        cell_type::QUADRATIC_TRIANGLE => {
            let (mut vtk, mut other) = (0.0, 0.0);
            for c in cells.conn.chunks_exact(6) {
                let m = [
                    mid(x(c[0]), x(c[1])),
                    mid(x(c[1]), x(c[2])),
                    mid(x(c[2]), x(c[0])),
                ];
                vtk += d(x(c[3]), m[0]) + d(x(c[4]), m[1]) + d(x(c[5]), m[2]);
                other += d(x(c[3]), m[1]) + d(x(c[4]), m[2]) + d(x(c[5]), m[0]);
            }
            if other < vtk {
                for c in cells.conn.chunks_exact_mut(6) {
                    let (a, b, e) = (c[3], c[4], c[5]);
                    // File order: opposite v0 (edge 1–2), opposite v1 (2–0), opposite v2 (0–1).
                    c[3] = e;
                    c[4] = a;
                    c[5] = b;
                }
                return Some(
                    "Triangle_6 mid nodes reordered to VTK's (the file lists the node \
                     opposite each vertex)"
                        .into(),
                );
            }
            None
        }
        cell_type::QUAD => {
            let cross = |o: [f64; 3], a: [f64; 3], b: [f64; 3]| {
                (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
            };
            let bowtie = |c: &[u32]| {
                let s1 = cross(x(c[0]), x(c[1]), x(c[2]));
                let s2 = cross(x(c[0]), x(c[2]), x(c[3]));
                s1 * s2 < 0.0
            };
            let n = cells.conn.len() / 4;
            let bad = cells.conn.chunks_exact(4).filter(|c| bowtie(c)).count();
            if n > 0 && bad * 2 > n {
                for c in cells.conn.chunks_exact_mut(4) {
                    c.swap(2, 3);
                }
                return Some(
                    "quadrilateral vertices reordered counter-clockwise (the file numbers them \
                     as a tensor product)"
                        .into(),
                );
            }
            None
        }
        _ => None,
    }
}

/// An attribute as an array over `n` tuples.
fn attribute(h: &mut Heavy, a: &Element, grid: &str) -> Result<(String, bool, DataArray)> {
    let name = a.attr("Name").unwrap_or("").to_string();
    let place = format!("<Grid> \"{grid}\" <Attribute> \"{name}\"");
    if name.is_empty() {
        return Err(h.err(&place, "has no Name"));
    }
    let center = a.attr("Center").unwrap_or("Node");
    let on_points = match center.to_ascii_lowercase().as_str() {
        "node" => true,
        "cell" => false,
        other => {
            return Err(h.err(
                &place,
                format!("Center=\"{other}\" is not supported (Node, Cell)"),
            ));
        }
    };
    let data = a
        .child("DataItem")
        .ok_or_else(|| h.err(&place, "has no <DataItem>"))?;
    let item = h.item(data, &place)?;
    let tuples = item.dims.first().copied().unwrap_or(item.values.len());
    let components = item.values.len().checked_div(tuples).unwrap_or(1);
    if tuples * components != item.values.len() || components == 0 {
        return Err(h.err(
            &place,
            format!(
                "{} values do not split into {tuples} tuples",
                item.values.len()
            ),
        ));
    }
    Ok((
        grid.to_string(),
        on_points,
        DataArray {
            name,
            scalar: item.scalar,
            components,
            component_names: Vec::new(),
            values: item.values,
        },
    ))
}

/// Reads an XDMF file (module doc).
pub fn read_xdmf(path: &Path, step: Option<StepChoice>) -> Result<VtuFile> {
    let bytes = container::read_bytes(path)?;
    let root = container::parse_xml(path, &bytes)?;
    let err = |place: &str, problem: String| Error::input(path, place, problem);
    if root.name != "Xdmf" {
        return Err(err(
            "root element",
            format!("is <{}>, not <Xdmf>: not an XDMF file", root.name),
        ));
    }
    let domain = root
        .child("Domain")
        .ok_or_else(|| err("<Xdmf>", "has no <Domain>".into()))?;
    let mut grids = Vec::new();
    collect(path, domain, None, &mut grids)?;
    let mut h = Heavy {
        xdmf: path,
        budget: Budget::global(),
        files: HashMap::new(),
    };
    let name_of = |g: &Element, k: usize| g.attr("Name").map_or(format!("{k}"), str::to_string);

    // The mesh: the first grid with its own 2D topology and geometry.
    let mesh_index = grids
        .iter()
        .position(|g| {
            matches!(part(g.el, "Geometry"), Part::Own(_))
                && match part(g.el, "Topology") {
                    Part::Own(t) => topology_type(
                        t.attr("TopologyType").or(t.attr("Type")).unwrap_or(""),
                        None,
                    )
                    .is_some_and(|(v, _)| is_2d(v)),
                    _ => false,
                }
        })
        .ok_or_else(|| {
            err(
                "<Domain>",
                "has no grid with its own Geometry and a 2D Topology (Triangle, Triangle_6, \
                 Quadrilateral, …): no mesh"
                    .into(),
            )
        })?;
    let mesh_grid = grids[mesh_index].el;
    let mesh_name = name_of(mesh_grid, mesh_index);
    let Part::Own(geo) = part(mesh_grid, "Geometry") else {
        unreachable!("the mesh grid has a geometry")
    };
    let Part::Own(top) = part(mesh_grid, "Topology") else {
        unreachable!("the mesh grid has a topology")
    };
    let (points, points_type) = geometry(&mut h, geo)?;
    let np = points.len();
    let mut cells = topology(&mut h, top, &format!("<Grid> \"{mesh_name}\""), Some(np))?;
    let mut notes = Vec::new();
    notes.extend(fix_order(&mut cells, &points));
    let nc = cells.conn.len() / cells.nodes;
    let same_text = |a: &Element, b: &Element| {
        let t = |e: &Element| e.child("DataItem").map(|d| d.text.trim().to_string());
        t(a).is_some() && t(a) == t(b)
    };
    let on_mesh = |g: &Element| {
        let geo_ok = match part(g, "Geometry") {
            Part::Mesh => true,
            Part::Own(e) => std::ptr::eq(e, geo) || same_text(e, geo),
            Part::None => false,
        };
        let top_ok = match part(g, "Topology") {
            Part::Mesh => true,
            Part::Own(e) => std::ptr::eq(e, top) || same_text(e, top),
            Part::None => false,
        };
        (geo_ok, top_ok)
    };

    // Time steps of the fields on the mesh.
    let mut times: Vec<f64> = grids
        .iter()
        .filter(|g| on_mesh(g.el) == (true, true))
        .filter_map(|g| g.time)
        .collect();
    times.sort_by(f64::total_cmp);
    times.dedup();
    let chosen = if times.is_empty() {
        if let Some(s) = step {
            return Err(Error::Usage(format!(
                "{s}: {} has no time series (no <Time> on its grids)",
                path.display()
            )));
        }
        None
    } else {
        Some(times[container::choose_step(path, &times, step)?])
    };

    let mut point_data: Vec<DataArray> = Vec::new();
    let mut cell_data: Vec<DataArray> = Vec::new();
    // Tag grids: boundary facets (lines) and cell tags.
    let mut lines: Vec<(u8, Vec<u32>)> = Vec::new();
    let mut line_index: HashMap<Vec<u32>, usize> = HashMap::new();
    let mut line_arrays: Vec<(DataArray, Vec<Option<f64>>)> = Vec::new();
    let mut cell_tag_arrays: Vec<DataArray> = Vec::new();
    let mut ignored: Vec<String> = Vec::new();
    let mut cell_keys: Option<HashMap<Vec<u32>, usize>> = None;
    for (k, g) in grids.iter().enumerate() {
        let gname = name_of(g.el, k);
        let attrs: Vec<&Element> = g.el.children_named("Attribute").collect();
        match on_mesh(g.el) {
            (true, true) => {
                if g.time.is_some() && g.time != chosen {
                    continue;
                }
                for a in attrs {
                    let (_, on_points, arr) = attribute(&mut h, a, &gname)?;
                    let (list, n, what) = if on_points {
                        (&mut point_data, np, "points")
                    } else {
                        (&mut cell_data, nc, "cells")
                    };
                    if arr.tuples() != n {
                        return Err(err(
                            &format!("<Grid> \"{gname}\" <Attribute> \"{}\"", arr.name),
                            format!("has {} tuples, the mesh has {n} {what}", arr.tuples()),
                        ));
                    }
                    if list.iter().any(|b| b.name == arr.name) {
                        return Err(err(
                            &format!("<Grid> \"{gname}\" <Attribute> \"{}\"", arr.name),
                            "appears twice at this time step".into(),
                        ));
                    }
                    list.push(arr);
                }
            }
            (true, false) => {
                let Part::Own(t) = part(g.el, "Topology") else {
                    continue;
                };
                let tag_cells = topology(&mut h, t, &format!("<Grid> \"{gname}\""), Some(np))?;
                let ntag = tag_cells.conn.len() / tag_cells.nodes;
                let mut arrays = Vec::new();
                for a in attrs {
                    let (_, on_points, arr) = attribute(&mut h, a, &gname)?;
                    if on_points || arr.tuples() != ntag || arr.components != 1 {
                        return Err(err(
                            &format!("<Grid> \"{gname}\" <Attribute> \"{}\"", arr.name),
                            format!(
                                "a tag grid needs one value per cell ({ntag}), Center=\"Cell\"; \
                                 it has {} tuples of {} components",
                                arr.tuples(),
                                arr.components
                            ),
                        ));
                    }
                    arrays.push(arr);
                }
                if is_2d(tag_cells.vtk) {
                    // Cell tags: onto the mesh cells with the same vertices.
                    let keys = cell_keys.get_or_insert_with(|| {
                        cells
                            .conn
                            .chunks_exact(cells.nodes)
                            .enumerate()
                            .map(|(i, c)| {
                                let mut v = c.to_vec();
                                v.sort_unstable();
                                (v, i)
                            })
                            .collect()
                    });
                    for arr in arrays {
                        let mut values = vec![0.0; nc];
                        for (i, c) in tag_cells.conn.chunks_exact(tag_cells.nodes).enumerate() {
                            let mut v = c.to_vec();
                            v.sort_unstable();
                            let cell = keys.get(&v).ok_or_else(|| {
                                err(
                                    &format!("<Grid> \"{gname}\" <Topology>"),
                                    format!("cell {i} is no cell of the mesh"),
                                )
                            })?;
                            values[*cell] = arr.values[i];
                        }
                        cell_tag_arrays.push(DataArray { values, ..arr });
                    }
                } else if tag_cells.vtk != cell_type::VERTEX {
                    let mut at = Vec::with_capacity(ntag);
                    for c in tag_cells.conn.chunks_exact(tag_cells.nodes) {
                        let mut key = c.to_vec();
                        key.sort_unstable();
                        let i = *line_index.entry(key).or_insert_with(|| {
                            lines.push((tag_cells.vtk, c.to_vec()));
                            lines.len() - 1
                        });
                        at.push(i);
                    }
                    for arr in arrays {
                        let mut values = vec![None; lines.len()];
                        for (i, &l) in at.iter().enumerate() {
                            values[l] = Some(arr.values[i]);
                        }
                        if line_arrays.iter().any(|(b, _)| b.name == arr.name) {
                            return Err(err(
                                &format!("<Grid> \"{gname}\" <Attribute> \"{}\"", arr.name),
                                "a tag array of this name comes twice".into(),
                            ));
                        }
                        line_arrays.push((arr, values));
                    }
                } else {
                    ignored.push(gname);
                }
            }
            _ => {
                if k != mesh_index {
                    ignored.push(gname);
                }
            }
        }
    }
    if !ignored.is_empty() {
        notes.push(format!(
            "grids not on the mesh ignored: {}",
            ignored.join(", ")
        ));
    }

    // Assemble: the 2D cells, then the tagged lines.
    let nlines = lines.len();
    let total = nc + nlines;
    let mut file = VtuFile::from_cells(path, points, &[]);
    file.point_components = if geo
        .attr("GeometryType")
        .is_some_and(|g| g.eq_ignore_ascii_case("XY"))
    {
        2
    } else {
        3
    };
    for c in cells.conn.chunks_exact(cells.nodes) {
        file.types.push(cells.vtk);
        file.connectivity.extend_from_slice(c);
        file.offsets.push(file.connectivity.len());
    }
    for (t, c) in &lines {
        file.types.push(*t);
        file.connectivity.extend_from_slice(c);
        file.offsets.push(file.connectivity.len());
    }
    let pad = |a: DataArray, before: usize, after: usize| {
        let n = a.components;
        let mut values = vec![0.0; before * n];
        values.extend_from_slice(&a.values);
        values.resize(values.len() + after * n, 0.0);
        DataArray { values, ..a }
    };
    let mut all_cells: Vec<DataArray> = cell_data
        .into_iter()
        .chain(cell_tag_arrays)
        .map(|a| pad(a, 0, nlines))
        .collect();
    for (arr, values) in line_arrays {
        let mut v: Vec<f64> = values.into_iter().map(|x| x.unwrap_or(0.0)).collect();
        v.resize(nlines, 0.0);
        if all_cells.iter().any(|b| b.name == arr.name) {
            return Err(err(
                &format!("tag array \"{}\"", arr.name),
                "has the name of a cell array of the mesh".into(),
            ));
        }
        all_cells.push(pad(DataArray { values: v, ..arr }, nc, 0));
    }
    debug_assert!(all_cells.iter().all(|a| a.tuples() == total));
    file.point_data = point_data;
    file.cell_data = all_cells;
    let version = root.attr("Version").unwrap_or("?");
    file.format = FileFormat {
        data_formats: vec![if h.files.is_empty() {
            "XML".into()
        } else {
            "HDF5".into()
        }],
        compressor: "none".into(),
        header_type: "-".into(),
        byte_order: "-".into(),
        pieces: 1,
        points_type: points_type.name().into(),
        container: container::describe(
            &format!(
                "XDMF {version}{}{}",
                match chosen {
                    Some(t) => format!(
                        " step {} (t = {t}; {} step{} in all)",
                        times.iter().position(|&s| s == t).unwrap_or(0),
                        times.len(),
                        if times.len() == 1 { "" } else { "s" }
                    ),
                    None => String::new(),
                },
                if nlines > 0 {
                    format!(", {nlines} tagged facets")
                } else {
                    String::new()
                }
            ),
            &notes,
        ),
    };
    Ok(file)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<VtuFile> {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.xdmf");
        std::fs::write(&p, text).unwrap();
        read_xdmf(&p, None)
    }

    /// Two P2 triangles on the unit square, inline XML, with DOLFINx's layout: a mesh grid, a
    /// facet-tag grid and a temporal collection of a function at two times.
    fn doc(order: &str) -> String {
        format!(
            r#"<?xml version="1.0"?>
<Xdmf Version="3.0" xmlns:xi="https://www.w3.org/2001/XInclude"><Domain>
<Grid Name="mesh" GridType="Uniform">
 <Topology TopologyType="Triangle_6" NumberOfElements="2" NodesPerElement="6">
  <DataItem Dimensions="2 6" NumberType="Int" Format="XML">{order}</DataItem></Topology>
 <Geometry GeometryType="XY"><DataItem Dimensions="9 2" Format="XML">
  0 0  1 0  0 1  1 1  0.5 0  0.5 0.5  0 0.5  1 0.5  0.5 1</DataItem></Geometry>
</Grid>
<Grid Name="facet_tags" GridType="Uniform">
 <xi:include xpointer="xpointer(/Xdmf/Domain/Grid/Geometry)" />
 <Topology TopologyType="Edge_3" NumberOfElements="2" NodesPerElement="3">
  <DataItem Dimensions="2 3" NumberType="Int" Format="XML">0 1 4  3 2 8</DataItem></Topology>
 <Attribute Name="facet_tags" AttributeType="Scalar" Center="Cell">
  <DataItem Dimensions="2 1" NumberType="Int" Format="XML">1 2</DataItem></Attribute>
</Grid>
<Grid Name="u" GridType="Collection" CollectionType="Temporal">
 <Grid Name="u" GridType="Uniform">
  <xi:include xpointer="xpointer(/Xdmf/Domain/Grid[@GridType='Uniform'][1]/*[self::Topology or self::Geometry])" />
  <Time Value="0" />
  <Attribute Name="u" AttributeType="Scalar" Center="Node">
   <DataItem Dimensions="9 1" Format="XML">0 0 0 0 0 0 0 0 0</DataItem></Attribute>
 </Grid>
 <Grid Name="u" GridType="Uniform">
  <xi:include xpointer="xpointer(/Xdmf/Domain/Grid[@GridType='Uniform'][1]/*[self::Topology or self::Geometry])" />
  <Time Value="1" />
  <Attribute Name="u" AttributeType="Scalar" Center="Node">
   <DataItem Dimensions="9 1" Format="XML">1 2 3 4 5 6 7 8 9</DataItem></Attribute>
 </Grid>
</Grid>
</Domain></Xdmf>
"#
        )
    }

    #[test]
    fn reads_inline_xdmf_with_tags_and_steps() {
        let f = parse(&doc("0 1 2 4 5 6  1 3 2 7 8 5")).unwrap();
        assert_eq!(f.types, vec![22, 22, 21, 21]);
        assert_eq!(f.cell(0), &[0, 1, 2, 4, 5, 6]);
        assert_eq!(f.cell(3), &[3, 2, 8]);
        assert_eq!(f.point_data[0].values[8], 9.0);
        let tags = &f.cell_data[0];
        assert_eq!(tags.name, "facet_tags");
        assert_eq!(tags.values, vec![0.0, 0.0, 1.0, 2.0]);
        assert!(
            f.format
                .container
                .contains("step 1 (t = 1; 2 steps in all)"),
            "{}",
            f.format.container
        );
    }

    #[test]
    fn triangle_6_in_the_opposite_vertex_order_is_permuted() {
        // Mid nodes listed opposite vertex 0, 1, 2: edge 1–2, 2–0, 0–1.
        let f = parse(&doc("0 1 2 5 6 4  1 3 2 8 5 7")).unwrap();
        assert_eq!(f.cell(0), &[0, 1, 2, 4, 5, 6]);
        assert_eq!(f.cell(1), &[1, 3, 2, 7, 8, 5]);
        assert!(
            f.format.container.contains("reordered"),
            "{}",
            f.format.container
        );
    }

    #[test]
    fn bad_xdmf_is_one_line() {
        let e = parse(&doc("0 1 2 4 5 6  1 3 2 7 8 9"))
            .unwrap_err()
            .to_string();
        assert!(
            e.ends_with("entry 11 (cell 1) is 9, not a point index below 9"),
            "{e}"
        );
        let text = doc("0 1 2 4 5 6  1 3 2 7 8 5");
        let e = parse(&text[..text.len() / 2]).unwrap_err().to_string();
        assert!(e.contains("truncated file?"), "{e}");
        let e = parse(&text.replace("Dimensions=\"2 6\"", "Dimensions=\"3 6\""))
            .unwrap_err()
            .to_string();
        assert!(
            e.ends_with("Dimensions \"3 6\" need 18 values, the data has 12"),
            "{e}"
        );
        let hdf = text.replace(
            "Format=\"XML\">0 1 4  3 2 8",
            "Format=\"HDF\">t.h5:/MeshTags/facet_tags/topology",
        );
        let e = parse(&hdf).unwrap_err().to_string();
        if cfg!(feature = "xdmf") {
            assert!(e.contains("t.h5 does not exist"), "{e}");
        } else {
            assert!(e.ends_with("t.xdmf: XDMF needs fosls built with --features xdmf (and libhdf5-dev): cargo build --release --features xdmf"), "{e}");
        }
    }
}
