//! Parallel VTU (`.pvtu`): the `<PUnstructuredGrid>` index of pieces written by VTK, ParaView,
//! DOLFINx (`VTKFile`, even in serial) and MFEM (`ParaViewDataCollection`).
//!
//! Every `<Piece Source=…>` (relative to the `.pvtu`) is read as the `.vtu` it is, its ghost
//! cells dropped ([`super::container`]); the arrays declared in `<PPointData>`/`<PCellData>`
//! must be in every piece with the declared component count (VTK's readers read only declared
//! arrays, so others are ignored); the pieces are joined with their starts in `piece_points`,
//! so that the mesh merges the points they share (ghost points included).

use std::path::Path;

use super::container::{self, Element, Stripped};
use super::vtu::{self, VtuFile};
use crate::error::{Error, Result};
use crate::limits::Budget;

/// The arrays of one `<PPointData>` or `<PCellData>`: (name, components), bookkeeping arrays
/// left out.
fn declared(path: &Path, section: Option<&Element>) -> Result<Vec<(String, usize)>> {
    let mut out: Vec<(String, usize)> = Vec::new();
    let Some(section) = section else {
        return Ok(out);
    };
    for (k, a) in section.children_named("PDataArray").enumerate() {
        let place = format!("<{}> PDataArray {k}", section.name);
        let name = a
            .attr("Name")
            .ok_or_else(|| Error::input(path, &place, "has no Name attribute"))?;
        let components = match a.attr("NumberOfComponents") {
            None => 1,
            Some(c) => c
                .trim()
                .parse::<usize>()
                .ok()
                .filter(|&c| (1..=1024).contains(&c))
                .ok_or_else(|| {
                    Error::input(
                        path,
                        format!("<{}> PDataArray \"{name}\"", section.name),
                        format!("NumberOfComponents \"{c}\" is not an integer in 1..=1024"),
                    )
                })?,
        };
        if out.iter().any(|(n, _)| n == name) {
            return Err(Error::input(
                path,
                format!("<{}> PDataArray \"{name}\"", section.name),
                "is declared twice",
            ));
        }
        if !["vtkGhostType", "vtkOriginalPointIds", "vtkOriginalCellIds"].contains(&name) {
            out.push((name.to_string(), components));
        }
    }
    Ok(out)
}

/// Reads a `.pvtu` and all its pieces (module doc).
pub fn read_pvtu(path: &Path, budget: &Budget) -> Result<VtuFile> {
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
        && t != "PUnstructuredGrid"
    {
        return Err(err(
            "<VTKFile>",
            format!("type is \"{t}\"; a .pvtu file is a PUnstructuredGrid"),
        ));
    }
    let grid = root.child("PUnstructuredGrid").ok_or_else(|| {
        let held = root
            .children
            .first()
            .map_or("nothing".to_string(), |c| format!("<{}>", c.name));
        err(
            "<VTKFile>",
            format!("holds {held}, not <PUnstructuredGrid>"),
        )
    })?;
    let points = declared(path, grid.child("PPointData"))?;
    let cells = declared(path, grid.child("PCellData"))?;
    if grid.child("PPoints").is_none() {
        return Err(err("<PUnstructuredGrid>", "has no <PPoints>".into()));
    }
    let pieces: Vec<&Element> = grid.children_named("Piece").collect();
    if pieces.is_empty() {
        return Err(err("<PUnstructuredGrid>", "has no <Piece>".into()));
    }
    let mut parts = Vec::with_capacity(pieces.len());
    let mut stripped = Stripped::default();
    for (k, piece) in pieces.iter().enumerate() {
        let place = format!("<Piece> {k}");
        let source = piece
            .attr("Source")
            .filter(|s| !s.trim().is_empty())
            .ok_or_else(|| err(&place, "has no Source attribute".into()))?;
        let file = container::relative_to(path, source.trim());
        if !file.is_file() {
            return Err(err(
                &format!("<Piece> {k} Source=\"{source}\""),
                format!("{} does not exist (missing piece)", file.display()),
            ));
        }
        let piece_bytes = container::read_vtu_bytes(&file)?;
        let mut f = vtu::parse_vtu_with(&file, &piece_bytes, budget)?;
        stripped.add(container::strip_bookkeeping(&mut f));
        parts.push((file, f));
    }
    let origin = format!("the PVTU {}", path.display());
    let mut file = container::concat(path, parts, Some((&points, &cells)), &origin)?;
    let mut notes = stripped.notes();
    if let Some(level) = grid.attr("GhostLevel")
        && level.trim() != "0"
    {
        notes.insert(0, format!("GhostLevel {}", level.trim()));
    }
    file.format.container = container::describe(
        &format!(
            "PVTU of {} piece{}",
            pieces.len(),
            if pieces.len() == 1 { "" } else { "s" }
        ),
        &notes,
    );
    Ok(file)
}
