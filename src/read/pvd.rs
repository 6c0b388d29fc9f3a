//! ParaView collections (`.pvd`): `<Collection>` of `<DataSet timestep= part= file=>`, as
//! DOLFINx's `VTKFile` and MFEM's `ParaViewDataCollection` write them.
//!
//! The time steps are the distinct `timestep` values in increasing order (a missing one counts
//! as 0); the last is read unless [`StepChoice`] says otherwise. The data sets of one step (its
//! parts, ordered by `part`) are `.vtu`, `.pvtu` or legacy `.vtk` files, relative to the `.pvd`;
//! several parts are joined like the pieces of a `.pvtu`.

use std::path::Path;

use super::container::{self, Container, StepChoice};
use super::vtu::VtuFile;
use crate::error::{Error, Result};
use crate::limits::Budget;

struct DataSet<'a> {
    index: usize,
    time: f64,
    part: i64,
    file: &'a str,
}

/// Reads the chosen step of a `.pvd` (module doc).
pub fn read_pvd(path: &Path, step: Option<StepChoice>) -> Result<VtuFile> {
    let bytes = container::read_bytes(path)?;
    let root = container::parse_xml(path, &bytes)?;
    let err = |place: &str, problem: String| Error::input(path, place, problem);
    if root.name != "VTKFile" {
        return Err(err(
            "root element",
            format!("is <{}>, not <VTKFile>: not a VTK XML file", root.name),
        ));
    }
    if let Some(t) = root.attr("type")
        && t != "Collection"
    {
        return Err(err(
            "<VTKFile>",
            format!("type is \"{t}\"; a .pvd file is a Collection"),
        ));
    }
    let collection = root
        .child("Collection")
        .ok_or_else(|| err("<VTKFile>", "has no <Collection>".into()))?;
    let mut sets = Vec::new();
    for (index, d) in collection.children_named("DataSet").enumerate() {
        let place = format!("<DataSet> {index}");
        let file = d
            .attr("file")
            .map(str::trim)
            .filter(|f| !f.is_empty())
            .ok_or_else(|| err(&place, "has no file attribute".into()))?;
        let time = match d.attr("timestep").map(str::trim) {
            None | Some("") => 0.0,
            Some(t) => t
                .parse::<f64>()
                .ok()
                .filter(|t| t.is_finite())
                .ok_or_else(|| {
                    err(
                        &format!("{place} timestep"),
                        format!("\"{t}\" is not a finite number"),
                    )
                })?,
        };
        let part = match d.attr("part").map(str::trim) {
            None | Some("") => 0,
            Some(p) => p.parse::<i64>().map_err(|_| {
                err(
                    &format!("{place} part"),
                    format!("\"{p}\" is not an integer"),
                )
            })?,
        };
        sets.push(DataSet {
            index,
            time,
            part,
            file,
        });
    }
    if sets.is_empty() {
        return Err(err("<Collection>", "has no <DataSet>".into()));
    }
    let mut times: Vec<f64> = sets.iter().map(|s| s.time).collect();
    times.sort_by(f64::total_cmp);
    times.dedup();
    let chosen = container::choose_step(path, &times, step)?;
    let t = times[chosen];
    let mut selected: Vec<&DataSet> = sets.iter().filter(|s| s.time == t).collect();
    selected.sort_by_key(|s| (s.part, s.index));

    let budget = Budget::global();
    let mut parts = Vec::with_capacity(selected.len());
    for s in &selected {
        let file = container::relative_to(path, s.file);
        if !file.is_file() {
            return Err(err(
                &format!("<DataSet> {} file=\"{}\"", s.index, s.file),
                format!("{} does not exist", file.display()),
            ));
        }
        let kind = Container::of(&file);
        if matches!(kind, Container::Pvd | Container::Xdmf) {
            return Err(err(
                &format!("<DataSet> {} file=\"{}\"", s.index, s.file),
                format!(
                    "is a {} collection; a .pvd step holds .vtu, .pvtu or .vtk files",
                    kind.name()
                ),
            ));
        }
        let f = container::read_dataset(&file, kind, &budget)?;
        parts.push((file, f));
    }
    let inner: Vec<String> = parts
        .iter()
        .map(|(_, f)| f.format.container.clone())
        .collect();
    let mut file = if parts.len() == 1 {
        let (_, mut f) = parts.pop().expect("one part");
        f.path = path.to_path_buf();
        f
    } else {
        let origin = format!("part {} ({})", selected[0].part, selected[0].file);
        container::concat(path, parts, None, &origin)?
    };
    let mut inner_list = inner.clone();
    inner_list.dedup();
    file.format.container = format!(
        "PVD step {chosen} (t = {t}; {} step{} in all{}) → {}",
        times.len(),
        if times.len() == 1 { "" } else { "s" },
        if selected.len() > 1 {
            format!(", {} parts", selected.len())
        } else {
            String::new()
        },
        inner_list.join(", ")
    );
    Ok(file)
}
