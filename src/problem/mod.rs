//! From the file and the scene to the problem the estimator works on: the discrete fields u_h
//! and σ_h (docs/design.md §4) and the boundary condition of every boundary edge (docs/design.md §2, §7).
//!
//! [`select_fields`] finds the displacement and the stress among the arrays of the solution
//! file, decides the stress layout and stores every tensor as a full 2×2 row-major
//! `[σxx, σxy, σyx, σyy]`. [`classify`] gives each boundary edge of the mesh the condition of
//! the first `[[boundary]]` that selects it, or [`Condition::Free`] (traction-free, docs/design.md
//! §7), together with the owning cell and the local edge index that orients it.
//!
//! Every refusal is one [`crate::Error::Input`] line naming the file it is about: the solution file
//! for what its arrays hold, the scene file for what a scene key asks and the file cannot give.
//! Findings that are not errors (a dropped z component, a non-symmetric stress, a tagged line
//! cell on an interior edge, overlapping selectors) are returned as `notes` for the report.

pub mod boundary;
pub mod fields;

pub use boundary::*;
pub use fields::*;

use crate::material::Elastic;
use crate::mesh::Mesh;
use crate::read::scene::{Norm, Scene};
use crate::topology::Topology;

/// The problem every stage works on (one context instead of one input struct per stage): the
/// mesh, its topology, the scene, the condition of every boundary edge, the norm preset, the
/// material law and the length scale ℓ of the equilibrium weight (docs/design.md §3).
#[derive(Clone, Copy)]
pub struct Context<'a> {
    pub mesh: &'a Mesh,
    pub topo: &'a Topology,
    pub scene: &'a Scene,
    pub edges: &'a [BoundaryEdge],
    pub norm: Norm,
    pub elastic: Elastic,
    /// ℓ in w_d = ℓ²/(2μ): the scene's `[estimate] length_scale`, else diam(Ω)/π.
    pub length_scale: f64,
}

impl<'a> Context<'a> {
    /// The context of a mesh, scene and boundary classification with the norm preset `norm`.
    pub fn new(
        mesh: &'a Mesh,
        topo: &'a Topology,
        scene: &'a Scene,
        edges: &'a [BoundaryEdge],
        norm: Norm,
    ) -> Context<'a> {
        let length_scale = scene.estimate.length_scale.unwrap_or_else(|| {
            crate::geometry::point_set_diameter(&mesh.points) / std::f64::consts::PI
        });
        Context {
            mesh,
            topo,
            scene,
            edges,
            norm,
            elastic: Elastic::new(&scene.material),
            length_scale,
        }
    }
}

/// The rigid motions the scene leaves free, as sentences for the report's notes (empty when
/// there are none or when the question does not apply).
///
/// Without a Dirichlet edge, only the contact edges hold the body, and frictionless contact
/// holds only motions along the contact direction n: a rigid motion ρ (translations e_x, e_y
/// and the rotation (−(y − y₀), x − x₀)/L about the centre x₀ of the mesh's box, L its
/// half-size) with ρ·n = 0 on every contact edge is free. Those are the kernel of the Gram
/// matrix G_ij = Σ_E ∫_E (ρ_i·n)(ρ_j·n) (two Gauss points on each edge's chord, ample for a
/// rank test). The problem then has a solution only for loads with no resultant along such a
/// ρ, unique only up to it, and the patch flows find no patch to take that load
/// (docs/design.md §5.10). Edges whose ray along n misses the obstacle (infinite gap) hold
/// nothing and are left out. With friction the tangential motions can be held, so nothing is
/// reported; with a Dirichlet edge nothing is free.
pub fn free_rigid_motions(ctx: &Context) -> Vec<String> {
    use crate::read::scene::BoundaryKind;
    let mesh = ctx.mesh;
    let mut contact = Vec::new();
    for be in ctx.edges {
        match be.condition {
            Condition::Dirichlet(_) => return Vec::new(),
            Condition::Contact(b) => {
                let BoundaryKind::Contact(spec) = &ctx.scene.boundaries[b].kind else {
                    continue;
                };
                if spec.friction > 0.0 {
                    return Vec::new();
                }
                contact.push((be, spec));
            }
            _ => {}
        }
    }
    let [xa, ya, xb, yb] = mesh.bounding_box();
    let x0 = [0.5 * (xa + xb), 0.5 * (ya + yb)];
    let half = (0.5 * (xb - xa)).max(0.5 * (yb - ya));
    if !(half > 0.0 && half.is_finite()) {
        return Vec::new();
    }
    let mut g = [[0.0f64; 3]; 3];
    // Gauss–Legendre on [0, 1], 2 points.
    let gauss = [0.5 - 0.5 / 3f64.sqrt(), 0.5 + 0.5 / 3f64.sqrt()];
    for (be, spec) in &contact {
        let t = be.cell as usize;
        let fam = mesh.family[t];
        let x = mesh.coords(t);
        let [i, j, _] = fam.edge_nodes(be.local as usize);
        let (a, b) = (x[i], x[j]);
        let d = [b[0] - a[0], b[1] - a[1]];
        let len = d[0].hypot(d[1]);
        if len == 0.0 {
            continue;
        }
        let n = spec.direction([d[1] / len, -d[0] / len]);
        // An edge whose ray along n never meets the obstacle can never hold anything.
        let mid = [a[0] + 0.5 * d[0], a[1] + 0.5 * d[1]];
        if !spec.gap_at(mid, n).is_finite() {
            continue;
        }
        for s in gauss {
            let p = [a[0] + s * d[0], a[1] + s * d[1]];
            let v = [
                n[0],
                n[1],
                (-(p[1] - x0[1]) * n[0] + (p[0] - x0[0]) * n[1]) / half,
            ];
            for r in 0..3 {
                for c in 0..3 {
                    g[r][c] += 0.5 * len * v[r] * v[c];
                }
            }
        }
    }
    let svd = faer::Mat::<f64>::from_fn(3, 3, |r, c| g[r][c])
        .svd()
        .expect("the SVD of a 3 × 3 matrix converges");
    let (sv, vm) = (svd.S().column_vector(), svd.V());
    let top = (0..3).map(|k| sv[k]).fold(0.0f64, f64::max);
    let mut out = Vec::new();
    for k in 0..3 {
        if top > 0.0 && sv[k] > crate::tolerance::FREE_MOTION_RELATIVE * top {
            continue;
        }
        let v = [vm[(0, k)], vm[(1, k)], vm[(2, k)]];
        let motion = if v[2].abs() <= crate::tolerance::FREE_MOTION_RELATIVE.sqrt() {
            let l = v[0].hypot(v[1]);
            format!("the translation along ({:.3}, {:.3})", v[0] / l, v[1] / l)
        } else {
            // ρ = (v₀ − v₂(y − y₀)/L, v₁ + v₂(x − x₀)/L) vanishes at its centre.
            let c = [x0[0] - v[1] * half / v[2], x0[1] + v[0] * half / v[2]];
            format!("the rotation about ({:.4e}, {:.4e})", c[0], c[1])
        };
        out.push(format!(
            "the scene leaves {motion} free: no Dirichlet boundary, and frictionless contact \
             holds only motions along its direction; a solution exists only for loads without \
             a resultant along it and is then not unique, and the patch reconstruction finds \
             no patch to take that load"
        ));
    }
    out
}

/// A committed fixture read the way `audit::run` reads it (tests of the reconstructions).
#[cfg(test)]
pub(crate) struct Fixture {
    pub data: crate::mesh::Dataset,
    pub topo: Topology,
    pub scene: Scene,
    pub edges: Vec<BoundaryEdge>,
    pub fields: Fields,
}

#[cfg(test)]
impl Fixture {
    /// The context of this fixture with the norm preset `norm`.
    pub fn context(&self, norm: Norm) -> Context<'_> {
        Context::new(&self.data.mesh, &self.topo, &self.scene, &self.edges, norm)
    }

    /// The file's displacement (panics if it has none).
    pub fn displacement(&self) -> Vec<[f64; 2]> {
        self.fields.displacement.clone().expect("a displacement")
    }
}

/// Reads `fixtures/<case>/solution.vtu` with its `scene.toml`; panics on any error.
#[cfg(test)]
pub(crate) fn fixture(case: &str) -> Fixture {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(case);
    let vtu = crate::read::vtu::read_vtu(&dir.join("solution.vtu")).unwrap();
    let data = crate::mesh::build(vtu).unwrap();
    let topo = crate::topology::build(&data).unwrap();
    let scene = crate::read::scene::load_scene(&dir.join("scene.toml")).unwrap();
    let fields = select_fields(&data, &scene).unwrap();
    let edges = classify(&data, &topo, &scene).unwrap().edges;
    Fixture {
        data,
        topo,
        scene,
        edges,
        fields,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Result;
    use crate::mesh;
    use crate::mesh::{Dataset, NONE};
    use crate::read::decode::Scalar;
    use crate::read::scene::parse_scene;
    use crate::read::vtu::DataArray;
    use crate::read::vtu::VtuFile;
    use crate::topology;
    use std::fmt;
    use std::path::Path;

    // The unit square on a 3×3 grid of points (i/2, j/2), point i + 3j, split into 8
    // counter-clockwise triangles (file cells 0..8), followed by line cells on the boundary.
    const TRIANGLES: usize = 8;

    /// Boundary line cells with their tags: bottom 1, right 2, top 3, left 4.
    const SIDES: [(u32, u32, f64); 8] = [
        (0, 1, 1.),
        (1, 2, 1.),
        (2, 5, 2.),
        (5, 8, 2.),
        (8, 7, 3.),
        (7, 6, 3.),
        (6, 3, 4.),
        (3, 0, 4.),
    ];

    fn grid_points() -> Vec<[f64; 3]> {
        (0..9)
            .map(|k| [(k % 3) as f64 / 2.0, (k / 3) as f64 / 2.0, 0.0])
            .collect()
    }

    fn grid_triangles(clockwise: bool) -> Vec<(u8, Vec<u32>)> {
        let mut cells = Vec::new();
        for j in 0..2u32 {
            for i in 0..2u32 {
                let a = i + 3 * j;
                let (b, c, d) = (a + 1, a + 4, a + 3);
                for t in [[a, b, c], [a, c, d]] {
                    let t = if clockwise { [t[0], t[2], t[1]] } else { t };
                    cells.push((5u8, t.to_vec()));
                }
            }
        }
        cells
    }

    /// The square with the given line cells and their tags in the cell array "boundary_tag"
    /// (0 on the triangles).
    fn square_with(lines: &[(u32, u32, f64)], clockwise: bool) -> VtuFile {
        let mut cells = grid_triangles(clockwise);
        cells.extend(lines.iter().map(|&(a, b, _)| (3u8, vec![a, b])));
        let mut f = VtuFile::from_cells(Path::new("m.vtu"), grid_points(), &cells);
        let mut tags = vec![0.0; TRIANGLES];
        tags.extend(lines.iter().map(|l| l.2));
        f.cell_data.push(array("boundary_tag", 1, tags));
        f
    }

    fn square() -> VtuFile {
        square_with(&SIDES, false)
    }

    fn array(name: &str, components: usize, values: Vec<f64>) -> DataArray {
        DataArray {
            name: name.into(),
            scalar: Scalar::Float64,
            components,
            component_names: vec![],
            values,
        }
    }

    /// A point array on the 9 points with the same tuple everywhere.
    fn uniform(name: &str, tuple: &[f64]) -> DataArray {
        array(name, tuple.len(), tuple.repeat(9))
    }

    /// A cell array on the 16 cells of `square()` with the same tuple everywhere.
    fn uniform_cells(name: &str, tuple: &[f64]) -> DataArray {
        array(name, tuple.len(), tuple.repeat(TRIANGLES + SIDES.len()))
    }

    fn named(mut a: DataArray, names: &[&str]) -> DataArray {
        a.component_names = names.iter().map(|s| s.to_string()).collect();
        a
    }

    fn build(f: VtuFile) -> (Dataset, Topology) {
        let d = mesh::build(f).unwrap_or_else(|e| panic!("{e}"));
        let t = topology::build(&d).unwrap_or_else(|e| panic!("{e}"));
        (d, t)
    }

    const MATERIAL: &str = "[material]\nyoungs_modulus = 1.0\npoisson_ratio = 0.3\n";

    fn scene(extra: &str) -> Scene {
        parse_scene(Path::new("scene.toml"), &format!("{MATERIAL}{extra}"))
            .unwrap_or_else(|e| panic!("{e}"))
    }

    fn fields(f: VtuFile, extra: &str) -> Result<Fields> {
        let (d, _) = build(f);
        select_fields(&d, &scene(extra))
    }

    /// The one-line message of a refusal.
    fn message<T: fmt::Debug>(r: Result<T>) -> String {
        let m = r.expect_err("should be refused").to_string();
        assert!(!m.contains('\n'), "not one line: {m}");
        m
    }

    /// The square with point arrays `u` (a valid displacement) and `extra`.
    fn with_points(extra: Vec<DataArray>) -> VtuFile {
        let mut f = square();
        f.point_data.push(uniform("u", &[0.0, 0.0]));
        f.point_data.extend(extra);
        f
    }

    fn nodal(fields: &Fields) -> (&[[f64; 4]], &str) {
        match &fields.stress {
            Stress::Nodal { values, layout, .. } => (values, layout),
            other => panic!("not nodal: {other:?}"),
        }
    }

    // -----------------------------------------------------------------------------------------
    // Displacement

    #[test]
    fn displacement_is_auto_detected_and_a_zero_z_dropped_silently() {
        let mut f = square();
        f.point_data.push(uniform("T", &[7.0]));
        let values: Vec<f64> = (0..9).flat_map(|k| [k as f64, -(k as f64), 0.0]).collect();
        f.point_data.push(array("Displacement", 3, values));
        let r = fields(f, "").unwrap();
        assert_eq!(r.displacement_name.as_deref(), Some("Displacement"));
        assert_eq!(r.displacement.as_ref().unwrap().len(), 9);
        assert_eq!(r.displacement.as_ref().unwrap()[4], [4.0, -4.0]);
        assert_eq!(r.stress, Stress::Absent);
        assert!(r.notes.is_empty(), "{:?}", r.notes);
    }

    #[test]
    fn non_zero_z_is_dropped_with_a_note() {
        let mut values = [1.0, 2.0, 0.0].repeat(9);
        values[3 * 4 + 2] = -0.001;
        let r = fields(
            with_points(vec![]).tap(|f| f.point_data[0] = array("disp", 3, values)),
            "",
        )
        .unwrap();
        assert_eq!(r.displacement, Some(vec![[1.0, 2.0]; 9]));
        assert_eq!(
            r.notes,
            vec![
                "displacement \"disp\" has 3 components: the z component is dropped \
                 (max |u_z| = 0.001)"
            ]
        );
    }

    /// `tap` for building a value in an expression.
    trait Tap: Sized {
        fn tap(mut self, f: impl FnOnce(&mut Self)) -> Self {
            f(&mut self);
            self
        }
    }
    impl Tap for VtuFile {}

    /// code_aster results as ParaView's MED reader names them: the concept padded to 8
    /// characters, then the field.
    #[test]
    fn code_aster_fields_are_found_by_their_field_names() {
        let mut f = square();
        f.point_data
            .push(named(uniform("RESU____DEPL", &[1.0, 2.0]), &["DX", "DY"]));
        f.point_data.push(named(
            uniform("RESU____SIEF_NOEU", &[1.0, 2.0, 3.0, 4.0]),
            &["SIXX", "SIYY", "SIZZ", "SIXY"],
        ));
        f.point_data.push(uniform("RESU____SIEQ_NOEU", &[5.0]));
        let r = fields(f, "").unwrap();
        assert_eq!(r.displacement_name.as_deref(), Some("RESU____DEPL"));
        assert_eq!(r.displacement.as_ref().unwrap()[0], [1.0, 2.0]);
        let (values, layout) = nodal(&r);
        assert_eq!(layout, "xx,yy,zz,xy");
        // [xx, xy, yx, yy]
        assert_eq!(values[0], [1.0, 4.0, 4.0, 2.0]);
        // Other names ending in DEPL are not taken.
        let mut g = square();
        g.point_data.push(uniform("my_long_name_DEPL", &[1.0, 2.0]));
        assert!(fields(g, "").is_err());
        let aster = super::fields::aster_field;
        assert_eq!(aster("DEPL"), Some("DEPL"));
        assert_eq!(aster("EVOL_NOLDEPL"), Some("DEPL"));
        assert_eq!(aster("a-b-c-d-DEPL"), None);
    }

    /// Kratos' names: `DISPLACEMENT` and the Voigt `CAUCHY_STRESS_VECTOR` (xx, yy, xy).
    #[test]
    fn kratos_fields_are_found_by_their_names() {
        let mut f = square();
        f.point_data.push(uniform("DISPLACEMENT", &[1.0, 2.0, 0.0]));
        f.point_data
            .push(uniform("CAUCHY_STRESS_VECTOR", &[1.0, 2.0, 3.0]));
        let r = fields(f, "").unwrap();
        assert_eq!(r.displacement_name.as_deref(), Some("DISPLACEMENT"));
        let (values, layout) = nodal(&r);
        assert_eq!(layout, "xx,yy,xy");
        // [xx, xy, yx, yy]
        assert_eq!(values[0], [1.0, 3.0, 3.0, 2.0]);
    }

    #[test]
    fn displacement_named_in_the_scene_wins() {
        let f = with_points(vec![uniform("w", &[3.0, 4.0])]);
        let r = fields(f, "[fields]\ndisplacement = \"w\"\n").unwrap();
        assert_eq!(r.displacement_name.as_deref(), Some("w"));
        assert_eq!(r.displacement.as_ref().unwrap()[0], [3.0, 4.0]);
    }

    #[test]
    fn displacement_errors() {
        let base = || {
            with_points(vec![uniform("T", &[1.0])])
                .tap(|f| f.cell_data.push(uniform_cells("c", &[0.0, 0.0])))
        };
        assert_eq!(
            message(fields(base(), "[fields]\ndisplacement = \"q\"\n")),
            "scene.toml: fields.displacement: no point array \"q\" in m.vtu (point arrays: \
             \"u\" (2 components), \"T\" (1 component))"
        );
        assert_eq!(
            message(fields(base(), "[fields]\ndisplacement = \"c\"\n")),
            "scene.toml: fields.displacement: no point array \"c\" in m.vtu (it is a cell \
             array; the displacement must be point data) (point arrays: \"u\" (2 components), \
             \"T\" (1 component))"
        );
        assert_eq!(
            message(fields(base(), "[fields]\ndisplacement = \"T\"\n")),
            "scene.toml: fields.displacement: point array \"T\" in m.vtu has 1 component; a \
             displacement needs 2 or 3 (point arrays: \"u\" (2 components), \"T\" (1 \
             component))"
        );
        // None: `u` is a scalar here, so it is no candidate.
        let mut none = square();
        none.point_data.push(uniform("u", &[1.0]));
        assert_eq!(
            message(fields(none, "")),
            "m.vtu: PointData: no displacement found (a point array named displacement, \
             displacements, disp or u with 2 or 3 components; point arrays: \"u\" (1 \
             component)); set [fields] displacement = \"…\" in scene.toml"
        );
        assert_eq!(
            message(fields(square(), "")),
            "m.vtu: PointData: no displacement found (a point array named displacement, \
             displacements, disp or u with 2 or 3 components; point arrays: none); set [fields] \
             displacement = \"…\" in scene.toml"
        );
        // A nodal stress and no displacement (a pure stress method): the displacement is left
        // to the reconstruction; a cell stress cannot stand in (the error above).
        let mut stress_only = square();
        stress_only
            .point_data
            .push(uniform("stress", &[1.0, 2.0, 3.0]));
        let r = fields(stress_only, "").unwrap();
        assert!(r.displacement.is_none() && r.displacement_name.is_none());
        assert!(matches!(r.stress, Stress::Nodal { .. }));
        let several = with_points(vec![uniform("DISP", &[0.0, 0.0, 0.0])]);
        assert_eq!(
            message(fields(several, "")),
            "m.vtu: PointData: several displacement candidates (\"u\", \"DISP\"); set [fields] \
             displacement = \"…\" in scene.toml (point arrays: \"u\" (2 components), \"DISP\" \
             (3 components))"
        );
        let mut nan = with_points(vec![]);
        nan.point_data[0].values[2 * 4 + 1] = f64::NAN;
        assert_eq!(
            message(fields(nan, "")),
            "m.vtu: point array \"u\": non-finite value NaN at point 4 (x = 0.5, y = 0.5)"
        );
    }

    // -----------------------------------------------------------------------------------------
    // Stress

    #[test]
    fn three_components_are_xx_yy_xy() {
        let r = fields(with_points(vec![uniform("stress", &[1.0, 2.0, 3.0])]), "").unwrap();
        let (values, layout) = nodal(&r);
        assert_eq!(layout, "xx,yy,xy");
        assert_eq!(values, vec![[1.0, 3.0, 3.0, 2.0]; 9]);
        assert!(r.notes.is_empty(), "{:?}", r.notes);
    }

    #[test]
    fn four_components_are_xx_yy_zz_xy_unless_ambiguous() {
        let r = fields(
            with_points(vec![uniform("Sigma", &[1.0, 2.0, 0.9, 3.0])]),
            "",
        )
        .unwrap();
        assert_eq!(nodal(&r), (&[[1.0, 3.0, 3.0, 2.0]; 9][..], "xx,yy,zz,xy"));

        // Components 2 and 3 equal everywhere: could be a symmetric row-major 2×2.
        let mut values = [1.0, 3.0, 3.0, 2.0].repeat(9);
        values[5 * 4 + 1] = 5.0;
        values[5 * 4 + 2] = 5.0 + 2f64.powi(-42); // within 1e-12 · 5
        let ambiguous = || with_points(vec![array("S", 4, values.clone())]);
        assert_eq!(
            message(fields(ambiguous(), "")),
            "m.vtu: point array \"S\": 4 components are ambiguous: xx,yy,zz,xy, or a row-major \
             2×2 xx,xy,yx,yy (components 2 and 3 are equal everywhere); give [fields] \
             stress_layout = \"…\" in scene.toml"
        );
        let r = fields(ambiguous(), "[fields]\nstress_layout = \"xx,xy,yx,yy\"\n").unwrap();
        let (v, layout) = nodal(&r);
        assert_eq!(layout, "xx,xy,yx,yy");
        assert_eq!(v[0], [1.0, 3.0, 3.0, 2.0]);
        assert_eq!(v[5], [1.0, 5.0, 5.0 + 2f64.powi(-42), 2.0]);
        assert_eq!(
            r.notes,
            vec![
                "stress \"S\" stores σxy and σyx separately: max |σxy − σyx| / max |σ| = 4.547e-14"
            ]
        );
        // The scene's layout must fit the array.
        assert_eq!(
            message(fields(
                ambiguous(),
                "[fields]\nstress_layout = \"xx,yy,xy\"\n"
            )),
            "scene.toml: fields.stress_layout: lists 3 components but point array \"S\" in \
             m.vtu has 4 components"
        );

        // Components 2, 3 and 4 equal: both readings give the same in-plane tensor.
        let r = fields(with_points(vec![uniform("s", &[1.0, 2.0, 2.0, 2.0])]), "").unwrap();
        assert_eq!(nodal(&r), (&[[1.0, 2.0, 2.0, 2.0]; 9][..], "xx,yy,zz,xy"));
        let r = fields(with_points(vec![uniform("s", &[0.0; 4])]), "").unwrap();
        assert_eq!(nodal(&r).0, &[[0.0; 4]; 9][..]);
    }

    #[test]
    fn six_components_are_vtk_symmetric_order() {
        let r = fields(
            with_points(vec![uniform("stress", &[1.0, 2.0, 9.0, 3.0, 0.0, 0.0])]),
            "",
        )
        .unwrap();
        assert_eq!(
            nodal(&r),
            (&[[1.0, 3.0, 3.0, 2.0]; 9][..], "xx,yy,zz,xy,yz,xz")
        );
        assert!(r.notes.is_empty(), "{:?}", r.notes);

        let r = fields(
            with_points(vec![uniform("stress", &[1.0, 2.0, 9.0, 3.0, 0.5, 0.0])]),
            "",
        )
        .unwrap();
        assert_eq!(
            r.notes,
            vec![
                "stress \"stress\": out-of-plane shear (yz, xz) is not zero (max 0.5, 1.667e-1 \
                 of max |σ|); the in-plane part is used"
            ]
        );
    }

    #[test]
    fn nine_components_are_row_major_and_asymmetry_is_noted() {
        let r = fields(
            with_points(vec![uniform(
                "cauchy_stress",
                &[1.0, 3.0, 0.0, 3.5, 2.0, 0.0, 0.0, 0.0, 9.0],
            )]),
            "",
        )
        .unwrap();
        assert_eq!(
            nodal(&r),
            (&[[1.0, 3.0, 3.5, 2.0]; 9][..], "xx,xy,xz,yx,yy,yz,zx,zy,zz")
        );
        assert_eq!(
            r.notes,
            vec![
                "stress \"cauchy_stress\" stores σxy and σyx separately: max |σxy − σyx| / max |σ| = 1.429e-1"
            ]
        );
    }

    #[test]
    fn other_counts_and_non_finite_stress_are_refused() {
        assert_eq!(
            message(fields(with_points(vec![uniform("stress", &[1.0; 5])]), "")),
            "m.vtu: point array \"stress\": has 5 components but a stress needs 3 (xx,yy,xy), \
             4 (xx,yy,zz,xy), 6 (xx,yy,zz,xy,yz,xz) or 9 (row-major); or give [fields] \
             stress_layout = \"…\" in scene.toml"
        );
        // …but any count goes with an explicit layout.
        let r = fields(
            with_points(vec![uniform("stress", &[1.0, 2.0, 3.0, 4.0, 5.0])]),
            "[fields]\nstress_layout = \"zz, xx, yz, xy, yy\"\n",
        )
        .unwrap();
        assert_eq!(nodal(&r).0[0], [2.0, 4.0, 4.0, 5.0]);

        let mut f = with_points(vec![uniform("stress", &[1.0, 2.0, 3.0])]);
        f.point_data[1].values[3 * 7 + 2] = f64::INFINITY;
        assert_eq!(
            message(fields(f, "")),
            "m.vtu: point array \"stress\": non-finite value inf at point 7 (x = 0.5, y = 1)"
        );
    }

    #[test]
    fn component_names_decide_the_layout() {
        let case = |names: &[&str], tuple: &[f64]| {
            fields(
                with_points(vec![named(uniform("stress", tuple), names)]),
                "",
            )
        };
        // Ambiguous by count, resolved by the names.
        let r = case(&["XX", "XY", "YX", "YY"], &[1.0, 3.0, 3.0, 2.0]).unwrap();
        assert_eq!(nodal(&r), (&[[1.0, 3.0, 3.0, 2.0]; 9][..], "xx,xy,yx,yy"));
        let r = case(
            &["sigma_xx", "Sigma_YY", "sigma_zz", "sigma_xy"],
            &[1.0, 3.0, 3.0, 2.0],
        )
        .unwrap();
        assert_eq!(nodal(&r), (&[[1.0, 2.0, 2.0, 3.0]; 9][..], "xx,yy,zz,xy"));
        // Abaqus-style 1-based indices.
        let r = case(&["S11", "S22", "S12"], &[1.0, 2.0, 3.0]).unwrap();
        assert_eq!(nodal(&r), (&[[1.0, 3.0, 3.0, 2.0]; 9][..], "xx,yy,xy"));
        // 0-based indices with separators.
        let r = case(&["0_0", "1_1", "[0][1]"], &[1.0, 2.0, 3.0]).unwrap();
        assert_eq!(nodal(&r), (&[[1.0, 3.0, 3.0, 2.0]; 9][..], "xx,yy,xy"));
        let r = case(&["Sxx", "s_xy", "SYY"], &[1.0, 3.0, 2.0]).unwrap();
        assert_eq!(nodal(&r), (&[[1.0, 3.0, 3.0, 2.0]; 9][..], "xx,xy,yy"));
        // Unrecognised names: back to the count, with a note.
        let r = case(&["a", "b", "c"], &[1.0, 2.0, 3.0]).unwrap();
        assert_eq!(nodal(&r), (&[[1.0, 3.0, 3.0, 2.0]; 9][..], "xx,yy,xy"));
        assert_eq!(
            r.notes,
            vec![
                "stress \"stress\": ComponentName attributes (a, b, c) not recognised as tensor \
                 components; layout inferred from the component count"
            ]
        );
        // Recognised but no layout.
        assert_eq!(
            message(case(&["xx", "yy", "YY"], &[1.0, 2.0, 3.0])),
            "m.vtu: point array \"stress\": ComponentName attributes (xx, yy, YY) do not form a \
             stress layout: component 'yy' appears twice; give [fields] stress_layout = \"…\" in \
             scene.toml"
        );
        // The scene's layout overrides the names.
        let r = fields(
            with_points(vec![named(
                uniform("stress", &[1.0, 2.0, 3.0]),
                &["xx", "xy", "yy"],
            )]),
            "[fields]\nstress_layout = \"xx,yy,xy\"\n",
        )
        .unwrap();
        assert_eq!(nodal(&r).0[0], [1.0, 3.0, 3.0, 2.0]);
    }

    #[test]
    fn cell_stress_is_read_on_the_triangles() {
        // Per-cell values: cell c holds (c, 10 + c, 100 + c); lines hold NaN, which is not read.
        let values: Vec<f64> = (0..TRIANGLES + SIDES.len())
            .flat_map(|c| {
                if c < TRIANGLES {
                    [c as f64, 10.0 + c as f64, 100.0 + c as f64]
                } else {
                    [f64::NAN; 3]
                }
            })
            .collect();
        let f = with_points(vec![]).tap(|f| f.cell_data.push(array("SIGMA", 3, values)));
        let r = fields(f, "").unwrap();
        match &r.stress {
            Stress::Cell {
                values,
                name,
                layout,
            } => {
                assert_eq!(name, "SIGMA");
                assert_eq!(layout, "xx,yy,xy");
                assert_eq!(values.len(), TRIANGLES);
                assert_eq!(values[5], [5.0, 105.0, 105.0, 15.0]);
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn stress_selection_rules_and_errors() {
        // Point data is preferred over cell data.
        let f = with_points(vec![uniform("stress", &[1.0, 2.0, 3.0])])
            .tap(|f| f.cell_data.push(uniform_cells("sigma", &[1.0, 2.0, 3.0])));
        let r = fields(f, "").unwrap();
        assert!(matches!(r.stress, Stress::Nodal { .. }));
        assert_eq!(
            r.notes,
            vec!["stress: point array \"stress\" is preferred over cell data (\"sigma\")"]
        );
        // Named in the scene: a cell array.
        let f = with_points(vec![uniform("stress", &[1.0, 2.0, 3.0])])
            .tap(|f| f.cell_data.push(uniform_cells("other", &[4.0, 5.0, 6.0])));
        let r = fields(f, "[fields]\nstress = \"other\"\n").unwrap();
        assert!(
            matches!(&r.stress, Stress::Cell { values, .. } if values[0] == [4.0, 6.0, 6.0, 5.0])
        );

        let two_points = with_points(vec![
            uniform("stress", &[1.0, 2.0, 3.0]),
            uniform("S", &[1.0, 2.0, 3.0]),
        ]);
        assert_eq!(
            message(fields(two_points, "")),
            "m.vtu: PointData: several stress candidates (\"stress\", \"S\"); set [fields] \
             stress = \"…\" in scene.toml"
        );
        let two_cells = with_points(vec![]).tap(|f| {
            f.cell_data
                .push(uniform_cells("stresses", &[1.0, 2.0, 3.0]));
            f.cell_data.push(uniform_cells("Sigma", &[1.0, 2.0, 3.0]));
        });
        assert_eq!(
            message(fields(two_cells, "")),
            "m.vtu: CellData: several stress candidates (\"stresses\", \"Sigma\"); set [fields] \
             stress = \"…\" in scene.toml"
        );
        assert_eq!(
            message(fields(with_points(vec![]), "[fields]\nstress = \"sxx\"\n")),
            "scene.toml: fields.stress: no point or cell array \"sxx\" in m.vtu (point arrays: \
             \"u\" (2 components); cell arrays: \"boundary_tag\" (1 component))"
        );
        let mut bad = uniform_cells("stress", &[1.0, 2.0, 3.0]);
        bad.values[3 * 5 + 1] = f64::NEG_INFINITY;
        let f = with_points(vec![]).tap(|f| f.cell_data.push(bad));
        assert_eq!(
            message(fields(f, "")),
            "m.vtu: cell array \"stress\": non-finite value -inf at cell 5"
        );
    }

    // -----------------------------------------------------------------------------------------
    // Boundary conditions

    const TAGGED: &str = r#"
[[boundary]]
name = "bottom"
tag = 1
kind = "dirichlet"
displacement = [0.0, 0.0]

[[boundary]]
name = "right"
tag = 2
kind = "neumann"
traction = [1.0, 0.0]

[[boundary]]
name = "top"
tag = 3
kind = "contact"
gap = "0.1"
"#;

    fn classified(f: VtuFile, extra: &str) -> Result<(Dataset, Topology, Boundaries)> {
        let (d, t) = build(f);
        let b = classify(&d, &t, &scene(extra))?;
        Ok((d, t, b))
    }

    /// The midpoint of each boundary edge with the given condition, sorted.
    fn midpoints(d: &Dataset, b: &Boundaries, condition: Condition) -> Vec<[f64; 2]> {
        let mut m: Vec<[f64; 2]> = b
            .edges
            .iter()
            .filter(|e| e.condition == condition)
            .map(|e| {
                let tri = d.mesh.cells[e.cell as usize];
                let k = e.local as usize;
                let (p, q) = (
                    d.mesh.points[tri[k] as usize],
                    d.mesh.points[tri[(k + 1) % 3] as usize],
                );
                [(p[0] + q[0]) / 2.0, (p[1] + q[1]) / 2.0]
            })
            .collect();
        m.sort_by(|a, b| a.partial_cmp(b).unwrap());
        m
    }

    /// Every boundary edge is listed once, in topology order, and runs counter-clockwise:
    /// its midpoint lies on ∂[0,1]² and the normal on the right of travel points out.
    fn check_orientation(d: &Dataset, t: &Topology, b: &Boundaries) {
        assert_eq!(
            b.edges.iter().map(|e| e.edge).collect::<Vec<_>>(),
            t.boundary_edges
        );
        for e in &b.edges {
            assert_eq!(t.cell_edges[e.cell as usize][e.local as usize], e.edge);
            let tri = d.mesh.cells[e.cell as usize];
            let k = e.local as usize;
            let (p, q) = (
                d.mesh.points[tri[k] as usize],
                d.mesh.points[tri[(k + 1) % 3] as usize],
            );
            let m = [(p[0] + q[0]) / 2.0, (p[1] + q[1]) / 2.0];
            let on_side = |v: f64| v == 0.0 || v == 1.0;
            assert!(on_side(m[0]) || on_side(m[1]), "{m:?} not on the boundary");
            let len = (q[0] - p[0]).hypot(q[1] - p[1]);
            let n = [(q[1] - p[1]) / len, -(q[0] - p[0]) / len];
            let out = [m[0] + 0.1 * n[0], m[1] + 0.1 * n[1]];
            let inside = |v: f64| (0.0..=1.0).contains(&v);
            assert!(
                !(inside(out[0]) && inside(out[1])),
                "normal {n:?} at {m:?} points inwards"
            );
            if d.mesh.degree == 2 {
                assert_eq!(tri[3 + k], t.edge_mid[e.edge as usize]);
            }
        }
    }

    #[test]
    fn tags_select_their_edges_and_the_rest_is_free() {
        let (d, t, b) = classified(square(), TAGGED).unwrap();
        check_orientation(&d, &t, &b);
        assert_eq!(b.edges.len(), 8);
        assert_eq!(
            midpoints(&d, &b, Condition::Dirichlet(0)),
            vec![[0.25, 0.0], [0.75, 0.0]]
        );
        assert_eq!(
            midpoints(&d, &b, Condition::Neumann(1)),
            vec![[1.0, 0.25], [1.0, 0.75]]
        );
        assert_eq!(
            midpoints(&d, &b, Condition::Contact(2)),
            vec![[0.25, 1.0], [0.75, 1.0]]
        );
        assert_eq!(
            midpoints(&d, &b, Condition::Free),
            vec![[0.0, 0.25], [0.0, 0.75]]
        );
        // Each edge knows its line cell.
        for e in &b.edges {
            assert_ne!(e.line, NONE);
            assert_eq!(t.line_edge[e.line as usize], e.edge);
        }
        assert_eq!(b.edges_of(2).count(), 2);
        assert_eq!(
            b.per_boundary,
            vec![
                BoundarySummary {
                    name: "bottom".into(),
                    edges: 2,
                    length: 1.0
                },
                BoundarySummary {
                    name: "right".into(),
                    edges: 2,
                    length: 1.0
                },
                BoundarySummary {
                    name: "top".into(),
                    edges: 2,
                    length: 1.0
                },
            ]
        );
        assert_eq!(
            b.notes,
            vec!["2 boundary edges (length 1) selected by no [[boundary]]: traction-free"]
        );
    }

    #[test]
    fn clockwise_input_is_still_oriented_outwards() {
        let (d, t, b) = classified(square_with(&SIDES, true), TAGGED).unwrap();
        assert!(d.report.reoriented > 0);
        check_orientation(&d, &t, &b);
        assert_eq!(
            midpoints(&d, &b, Condition::Contact(2)),
            vec![[0.25, 1.0], [0.75, 1.0]]
        );
    }

    #[test]
    fn tagged_interior_line_is_ignored_with_a_note() {
        let mut lines = SIDES.to_vec();
        lines.push((0, 4, 3.0)); // the diagonal of the lower-left square: interior
        let (d, _, b) = classified(square_with(&lines, false), TAGGED).unwrap();
        assert_eq!(
            midpoints(&d, &b, Condition::Contact(2)),
            vec![[0.25, 1.0], [0.75, 1.0]]
        );
        assert_eq!(
            b.notes[0],
            "boundary[2] \"top\": 1 line cell with tag 3 lies on an interior edge and is ignored \
             (cell 16)"
        );
    }

    #[test]
    fn where_tests_the_edge_midpoint() {
        let text = r#"
[[boundary]]
name = "lid"
where = "y > 0.999"
kind = "dirichlet"
displacement = [0.0, "-0.01 * x"]

[[boundary]]
name = "sides"
where = "abs(x - 0.5) > 0.499"
kind = "neumann"
traction = [0.0, 0.0]
"#;
        // No line cells at all: `where` needs none.
        let (d, t, b) = classified(square_with(&[], false), text).unwrap();
        check_orientation(&d, &t, &b);
        // The corner edges of the sides end at y = 1 but their midpoints do not pass y > 0.999.
        assert_eq!(
            midpoints(&d, &b, Condition::Dirichlet(0)),
            vec![[0.25, 1.0], [0.75, 1.0]]
        );
        assert_eq!(
            midpoints(&d, &b, Condition::Neumann(1)),
            vec![[0.0, 0.25], [0.0, 0.75], [1.0, 0.25], [1.0, 0.75]]
        );
        assert_eq!(
            midpoints(&d, &b, Condition::Free),
            vec![[0.25, 0.0], [0.75, 0.0]]
        );
        assert!(b.edges.iter().all(|e| e.line == NONE));
        assert_eq!(b.per_boundary[1].length, 2.0);
    }

    #[test]
    fn where_uses_the_mid_node_of_quadratic_edges() {
        // One quadratic triangle whose bottom edge bulges down to (0.5, -0.1).
        let f = VtuFile::from_cells(
            Path::new("m.vtu"),
            vec![
                [0., 0., 0.],
                [1., 0., 0.],
                [0., 1., 0.],
                [0.5, -0.1, 0.],
                [0.5, 0.5, 0.],
                [0., 0.5, 0.],
            ],
            &[(22, vec![0, 1, 2, 3, 4, 5])],
        );
        let text = r#"
[[boundary]]
name = "bulge"
where = "y < -0.05"
kind = "contact"
gap = "0"
"#;
        let (d, t, b) = classified(f, text).unwrap();
        assert_eq!(d.mesh.degree, 2);
        let contact: Vec<&BoundaryEdge> = b.edges_of(0).collect();
        assert_eq!(contact.len(), 1);
        assert_eq!(contact[0].local, 0);
        assert_eq!(t.edge_mid[contact[0].edge as usize], 3);
        // Chord length, not arc length.
        assert_eq!(b.per_boundary[0].length, 1.0);
    }

    #[test]
    fn overlapping_selectors_first_in_file_order_wins() {
        let text = format!(
            "{TAGGED}{}",
            r#"
[[boundary]]
name = "floor"
where = "y < 0.001 && x > 0.5"
kind = "contact"
gap = "0"

[[boundary]]
name = "corner"
where = "x < 0.001 || y > 0.999"
kind = "neumann"
traction = [0.0, 0.0]
"#
        );
        let (d, _, b) = classified(square(), &text).unwrap();
        assert_eq!(
            midpoints(&d, &b, Condition::Dirichlet(0)),
            vec![[0.25, 0.0], [0.75, 0.0]]
        );
        assert_eq!(b.edges_of(3).count(), 0);
        assert_eq!(
            midpoints(&d, &b, Condition::Neumann(4)),
            vec![[0.0, 0.25], [0.0, 0.75]]
        );
        assert_eq!(b.per_boundary[3].edges, 0);
        assert_eq!(
            b.notes,
            vec![
                "boundary[0] \"bottom\" and boundary[3] \"floor\" both select 1 edge; boundary[0] \
                 \"bottom\" (first in file order) applies there",
                "boundary[2] \"top\" and boundary[4] \"corner\" both select 2 edges; boundary[2] \
                 \"top\" (first in file order) applies there",
            ]
        );
    }

    #[test]
    fn selector_errors_name_the_scene_key() {
        let boundary = |selector: &str| {
            format!(
                "[[boundary]]\nname = \"b\"\n{selector}\nkind = \"neumann\"\ntraction = [0, 0]\n"
            )
        };
        let err = |f: VtuFile, text: &str| message(classified(f, text));

        // Default tag array name missing; integer cell arrays are listed.
        let mut f = square();
        f.cell_data[0].name = "gmsh:physical".into();
        f.cell_data.push(uniform_cells("stress", &[0.5, 0.0, 0.0]));
        f.cell_data.push(uniform_cells("region", &[2.0]));
        assert_eq!(
            err(f, &boundary("tag = 1")),
            "scene.toml: boundary[0] \"b\".tag: cell array \"boundary_tag\" is not in m.vtu \
             (integer cell arrays: \"gmsh:physical\", \"region\"); name the tag array with \
             [boundaries] tag_array = \"…\""
        );
        // A named tag array that is point data.
        let f = square().tap(|f| f.point_data.push(uniform("ids", &[1.0])));
        assert_eq!(
            err(
                f,
                &format!("[boundaries]\ntag_array = \"ids\"\n{}", boundary("tag = 1"))
            ),
            "scene.toml: boundary[0] \"b\".tag: cell array \"ids\" is not in m.vtu (it is a \
             point array; tags are cell data on the line cells)"
        );
        // No line cells at all.
        let f = square_with(&[], false).tap(|f| f.cell_data.clear());
        assert_eq!(
            err(f, &boundary("tag = 1")),
            "scene.toml: boundary[0] \"b\".tag: cell array \"boundary_tag\" is not in m.vtu, \
             which has no line cells to carry tags; select edges with where = \"…\""
        );
        // A tag array with two components.
        let f = square().tap(|f| f.cell_data.push(uniform_cells("pair", &[1.0, 2.0])));
        assert_eq!(
            err(
                f,
                &format!(
                    "[boundaries]\ntag_array = \"pair\"\n{}",
                    boundary("tag = 1")
                )
            ),
            "scene.toml: boundary[0] \"b\".tag: cell array \"pair\" in m.vtu has 2 components; \
             a tag array needs 1"
        );
        // A tag no line cell carries.
        let mut f = square();
        f.cell_data[0].values[TRIANGLES] = 1.5;
        assert_eq!(
            err(f, &boundary("tag = 7")),
            "scene.toml: boundary[0] \"b\".tag: no line cell of m.vtu has tag 7 in cell array \
             \"boundary_tag\" (tags present: 1 (1 line cell), 2 (2 line cells), 3 (2 line \
             cells), 4 (2 line cells), 1 value not an integer)"
        );
        // Only interior line cells carry it.
        let mut lines = SIDES.to_vec();
        lines.push((0, 4, 9.0));
        lines.push((4, 8, 9.0));
        assert_eq!(
            err(square_with(&lines, false), &boundary("tag = 9")),
            "scene.toml: boundary[0] \"b\".tag: all 2 line cells with tag 9 in m.vtu lie on \
             interior edges, not on the boundary (cells 16, 17)"
        );
        lines.pop();
        assert_eq!(
            err(square_with(&lines, false), &boundary("tag = 9")),
            "scene.toml: boundary[0] \"b\".tag: the line cell with tag 9 in m.vtu lies on an \
             interior edge, not on the boundary (cell 16)"
        );
        // An expression true nowhere on the boundary (the centre is not on it).
        assert_eq!(
            err(
                square(),
                &boundary("where = \"abs(x - 0.5) + abs(y - 0.5) < 0.1\"")
            ),
            "scene.toml: boundary[0] \"b\".where: \"abs(x - 0.5) + abs(y - 0.5) < 0.1\" holds \
             at no boundary edge midpoint (the mesh spans x ∈ [0, 1], y ∈ [0, 1])"
        );
    }

    #[test]
    fn no_boundaries_leave_everything_free() {
        let (_, _, b) = classified(square(), "").unwrap();
        assert!(b.edges.iter().all(|e| e.condition == Condition::Free));
        assert!(b.per_boundary.is_empty());
        assert_eq!(
            b.notes,
            vec!["8 boundary edges (length 4) selected by no [[boundary]]: traction-free"]
        );
    }
}
