//! The scene model (docs/design.md §7): material, fields, boundaries with their conditions,
//! loads and estimate settings, as validated plain structs. [`crate::read::scene`] parses the
//! TOML file into it.

use std::fmt;
use std::path::PathBuf;

use crate::error::Error;
use crate::expr::Expr;

/// The cell-data array holding boundary tags when `[boundaries] tag_array` is not given.
pub const DEFAULT_TAG_ARRAY: &str = "boundary_tag";

/// A validated scene file.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// The file it was read from (for messages about it in later stages).
    pub file: PathBuf,
    pub material: Material,
    pub fields: FieldNames,
    /// `[loads] body_force`: f = (f_x, f_y) as expressions in x, y; `None` = no body force.
    pub body_force: Option<[Expr; 2]>,
    /// `[boundaries] tag_array` as written; see [`Scene::tag_array_name`].
    pub tag_array: Option<String>,
    /// The `[[boundary]]` tables in file order. Unselected edges are traction-free.
    pub boundaries: Vec<Boundary>,
    pub estimate: Estimate,
    /// `[body]`: which body (connected component of the cells) of a multi-body file to audit;
    /// `None` = the only one, or the one the boundary conditions support (docs/design.md §4.2).
    pub body: Option<BodySelector>,
}

/// `[body]`: one of three ways to name a body (docs/design.md §4.2, §7).
#[derive(Clone, Debug, PartialEq)]
pub enum BodySelector {
    /// `index = N`: the body's index (bodies are numbered by their first cell in the file).
    Index(usize),
    /// `cell_data = { name, value }`: the body holding every cell whose value in the
    /// one-component cell array `name` equals `value`.
    CellData { name: String, value: f64 },
    /// `where = "expr"`: the body holding every cell whose centroid (the mean of its
    /// vertices) satisfies the expression (> 0).
    Where(Expr),
}

/// `[material]`: linear isotropic elasticity.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// E > 0.
    pub youngs_modulus: f64,
    /// ν ∈ (−1, 0.5].
    pub poisson_ratio: f64,
    pub model: Model,
}

/// The 2D model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Model {
    PlaneStrain,
    PlaneStress,
}

/// `[fields]`: which arrays of the VTU file to read; `None` = auto-detect.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FieldNames {
    /// Point-data array with the displacement (for a list of component arrays, the name of the
    /// array joined from them, `(ux, uy)`: [`crate::read::components`]).
    pub displacement: Option<String>,
    /// The displacement's component arrays (x, y[, z]) when the scene lists them, else empty.
    pub displacement_parts: Vec<String>,
    /// Point- or cell-data array with the stress (joined name for a list, as above).
    pub stress: Option<String>,
    /// The stress's component arrays when the scene lists them, else empty.
    pub stress_parts: Vec<String>,
    /// Component order of the stress array; inferred from the component count when `None`.
    pub stress_layout: Option<StressLayout>,
}

/// One `[[boundary]]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Boundary {
    /// Position among the `[[boundary]]` tables (from 0), for messages.
    pub index: usize,
    /// Unique, non-empty.
    pub name: String,
    pub selector: Selector,
    pub kind: BoundaryKind,
}

/// Which boundary edges a [`Boundary`] applies to.
#[derive(Clone, Debug, PartialEq)]
pub enum Selector {
    /// `tag = n`: line cells whose value in the tag array ([`Scene::tag_array_name`]) is n.
    Tag(i64),
    /// `where = "expression"`: edges where the expression is true (> 0); how an edge is tested
    /// (midpoint, all nodes) is the mesh stage's decision.
    Where(Expr),
}

/// The boundary condition.
#[derive(Clone, Debug, PartialEq)]
pub enum BoundaryKind {
    /// u = u_D.
    Dirichlet { displacement: [Expr; 2] },
    /// σn = t.
    Neumann { traction: [Expr; 2] },
    /// Signorini contact, with Coulomb friction when `friction > 0`.
    Contact(Contact),
}

/// A contact boundary Γ_C.
#[derive(Clone, Debug, PartialEq)]
pub struct Contact {
    pub gap: Gap,
    pub normal: ContactNormal,
    /// 𝔉 ≥ 0, finite; 0 = frictionless.
    pub friction: f64,
}

/// Where the obstacle is.
#[derive(Clone, Debug, PartialEq)]
pub enum Gap {
    /// `obstacle = { plane = { point, normal } }`: a rigid plane through `point` with unit
    /// `normal` m pointing from the obstacle towards the body (normalised on reading).
    Plane { point: [f64; 2], normal: [f64; 2] },
    /// `gap = "expression"`: g given directly (only with `normal = "body"`).
    Expr(Expr),
}

/// The direction n in which u_n and g are measured (docs/design.md §2, §7).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ContactNormal {
    /// n = n_Ω, the outward normal of the body (the default).
    Body,
    /// n = −m, opposite to the plane obstacle's normal.
    Obstacle,
}

/// `[estimate]`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Estimate {
    /// As written; see [`Scene::effective_norm`].
    pub norm: Option<Norm>,
    /// ℓ > 0 in w_d = ℓ²/(2μ); `None` = diameter(Ω)/π.
    pub length_scale: Option<f64>,
}

/// Norm/weight preset of the functional (docs/design.md §3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Norm {
    Energy,
    Robust,
    Seed,
}

impl Norm {
    /// The name used in the scene file and the report.
    pub fn as_str(self) -> &'static str {
        match self {
            Norm::Energy => "energy",
            Norm::Robust => "robust",
            Norm::Seed => "seed",
        }
    }
}

impl fmt::Display for Norm {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl Model {
    /// The name used in the scene file and the report.
    pub fn as_str(self) -> &'static str {
        match self {
            Model::PlaneStrain => "plane_strain",
            Model::PlaneStress => "plane_stress",
        }
    }
}

impl fmt::Display for Model {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl Material {
    /// Shear modulus μ = E/(2(1+ν)).
    pub fn mu(&self) -> f64 {
        self.youngs_modulus / (2.0 * (1.0 + self.poisson_ratio))
    }

    /// The three-dimensional Lamé λ = Eν/((1+ν)(1−2ν)); `f64::INFINITY` at ν = 0.5.
    pub fn lame_lambda(&self) -> f64 {
        let (e, nu) = (self.youngs_modulus, self.poisson_ratio);
        if nu == 0.5 {
            f64::INFINITY
        } else {
            e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
        }
    }

    /// The λ of the 2D model, the one to use in Cε = 2μ ε + λ tr(ε) I and in the compliance
    /// A (with d = 2):
    ///
    /// - plane strain: the Lamé λ ([`Material::lame_lambda`]), `f64::INFINITY` at ν = 0.5;
    /// - plane stress: λ* = 2λμ/(λ+2μ). Inserting λ and μ,
    ///   λ + 2μ = E(1−ν)/((1+ν)(1−2ν)) and 2λμ = E²ν/((1+ν)²(1−2ν)), so
    ///   λ* = Eν/(1−ν²): finite for every ν ∈ (−1, 0.5], and at ν = 0.5 λ* = 2E/3 = 2μ, the
    ///   limit of 2λμ/(λ+2μ) → 2μ as λ → ∞. It is computed in this closed form.
    pub fn lambda(&self) -> f64 {
        match self.model {
            Model::PlaneStrain => self.lame_lambda(),
            Model::PlaneStress => {
                let (e, nu) = (self.youngs_modulus, self.poisson_ratio);
                e * nu / (1.0 - nu * nu)
            }
        }
    }

    /// Whether the material is incompressible (ν = 0.5), which forces the `robust` norm.
    /// (In plane strain λ is then infinite; in plane stress λ* = 2μ stays finite.)
    pub fn is_incompressible(&self) -> bool {
        self.poisson_ratio >= 0.5
    }
}

impl Scene {
    /// The norm to use: the one given, else `energy`, or `robust` when the model's λ is
    /// infinite (plane strain, ν = 0.5). An explicit `energy` with infinite λ was refused on
    /// reading.
    pub fn effective_norm(&self) -> Norm {
        self.estimate
            .norm
            .unwrap_or(if self.material.is_incompressible() {
                Norm::Robust
            } else {
                Norm::Energy
            })
    }

    /// Whether some boundary selects its edges by tag.
    pub fn uses_tags(&self) -> bool {
        self.boundaries
            .iter()
            .any(|b| matches!(b.selector, Selector::Tag(_)))
    }

    /// The cell-data array to read tags from: `[boundaries] tag_array` if given, else
    /// [`DEFAULT_TAG_ARRAY`] when some boundary uses a tag, else `None`.
    pub fn tag_array_name(&self) -> Option<&str> {
        match &self.tag_array {
            Some(name) => Some(name),
            None if self.uses_tags() => Some(DEFAULT_TAG_ARRAY),
            None => None,
        }
    }

    /// An input error about this scene file at `place` (e.g. [`Boundary::place`]).
    pub fn error(&self, place: impl fmt::Display, problem: impl fmt::Display) -> Error {
        Error::input(&self.file, place, problem)
    }
}

impl Boundary {
    /// `boundary[2] "arc"`: how messages name this boundary.
    pub fn label(&self) -> String {
        label(self.index, Some(&self.name))
    }

    /// `boundary[2] "arc".key`: how messages name one of its keys, e.g. the selector's
    /// ([`Selector::key`]).
    pub fn place(&self, key: &str) -> String {
        join(&self.label(), key)
    }

    /// The contact data, if this is a contact boundary.
    pub fn contact(&self) -> Option<&Contact> {
        match &self.kind {
            BoundaryKind::Contact(c) => Some(c),
            _ => None,
        }
    }
}

impl Selector {
    /// The scene key of this selector: `tag` or `where`.
    pub fn key(&self) -> &'static str {
        match self {
            Selector::Tag(_) => "tag",
            Selector::Where(_) => "where",
        }
    }
}

impl BoundaryKind {
    /// The scene name of the kind.
    pub fn as_str(&self) -> &'static str {
        match self {
            BoundaryKind::Dirichlet { .. } => "dirichlet",
            BoundaryKind::Neumann { .. } => "neumann",
            BoundaryKind::Contact(_) => "contact",
        }
    }
}

impl Contact {
    /// The contact direction n at a boundary point whose outward unit normal is `n_body`:
    /// `n_body` for [`ContactNormal::Body`], −m for [`ContactNormal::Obstacle`] (always a
    /// plane, enforced on reading).
    pub fn direction(&self, n_body: [f64; 2]) -> [f64; 2] {
        match (self.normal, &self.gap) {
            (ContactNormal::Obstacle, Gap::Plane { normal: m, .. }) => [-m[0], -m[1]],
            _ => n_body,
        }
    }

    /// The gap g at the boundary point `x` measured along the contact direction `n`
    /// (from [`Contact::direction`]); see [`Gap::along`].
    pub fn gap_at(&self, x: [f64; 2], n: [f64; 2]) -> f64 {
        self.gap.along(x, n)
    }
}

impl Gap {
    /// The gap at `x` along the unit direction `n`:
    ///
    /// - plane with point p and normal m: the distance g ≥ 0 such that x + g n lies on the
    ///   plane, g = m·(x − p) / (−m·n). With n = −m this is m·(x − p). Where the ray does not
    ///   meet the plane (m·n ≥ 0) the gap is `f64::INFINITY` (never in contact); a point
    ///   behind the plane gets a negative gap (penetration).
    /// - expression: its value at (x, y, 0), whatever n.
    pub fn along(&self, x: [f64; 2], n: [f64; 2]) -> f64 {
        match self {
            Gap::Plane {
                point: p,
                normal: m,
            } => {
                let distance = m[0] * (x[0] - p[0]) + m[1] * (x[1] - p[1]);
                let approach = -(m[0] * n[0] + m[1] * n[1]);
                if approach <= 0.0 {
                    f64::INFINITY
                } else {
                    distance / approach
                }
            }
            Gap::Expr(g) => g.eval(x[0], x[1], 0.0),
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Stress layout

/// One component of a stress tensor.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Component {
    Xx,
    Yy,
    Zz,
    Xy,
    Yx,
    Xz,
    Zx,
    Yz,
    Zy,
}

const COMPONENT_NAMES: [(&str, Component); 9] = [
    ("xx", Component::Xx),
    ("yy", Component::Yy),
    ("zz", Component::Zz),
    ("xy", Component::Xy),
    ("yx", Component::Yx),
    ("xz", Component::Xz),
    ("zx", Component::Zx),
    ("yz", Component::Yz),
    ("zy", Component::Zy),
];

impl Component {
    /// `xx`, `yy`, …
    pub fn as_str(self) -> &'static str {
        COMPONENT_NAMES
            .iter()
            .find(|(_, c)| *c == self)
            .map(|(name, _)| *name)
            .expect("every component has a name")
    }
}

/// The order of the components of a stress array, e.g. `xx,yy,zz,xy`.
///
/// Parsed from a comma-separated list, case-insensitive, spaces ignored, of distinct
/// components among xx, yy, zz, xy, yx, xz, zx, yz, zy, which must include xx, yy and xy or
/// yx. The layouts of docs/design.md §4 are [`StressLayout::for_component_count`] of 3, 4, 6, 9.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StressLayout {
    components: Vec<Component>,
}

impl StressLayout {
    /// Parses e.g. `"xx,yy,zz,xy"` or `"XX, YY, XY"`; the error is one line.
    pub fn parse(text: &str) -> std::result::Result<StressLayout, String> {
        let compact: String = text
            .chars()
            .filter(|c| !c.is_whitespace())
            .collect::<String>()
            .to_lowercase();
        if compact.is_empty() {
            return Err("empty layout: give components like \"xx,yy,xy\"".to_string());
        }
        let mut components = Vec::new();
        for (i, name) in compact.split(',').enumerate() {
            if name.is_empty() {
                return Err(format!("component {} is empty", i + 1));
            }
            let Some(&(_, c)) = COMPONENT_NAMES.iter().find(|(n, _)| *n == name) else {
                return Err(format!(
                    "unknown component '{}' (components: xx, yy, zz, xy, yx, xz, zx, yz, zy)",
                    name.escape_debug()
                ));
            };
            if components.contains(&c) {
                return Err(format!("component '{name}' appears twice"));
            }
            components.push(c);
        }
        let layout = StressLayout { components };
        for needed in [Component::Xx, Component::Yy] {
            if layout.index(needed).is_none() {
                return Err(format!("component '{}' is missing", needed.as_str()));
            }
        }
        if layout.index(Component::Xy).is_none() && layout.index(Component::Yx).is_none() {
            return Err("component 'xy' (or 'yx') is missing".to_string());
        }
        Ok(layout)
    }

    /// The usual layout for a component count (docs/design.md §4): 3 = xx,yy,xy;
    /// 4 = xx,yy,zz,xy; 6 = xx,yy,zz,xy,yz,xz (VTK symmetric order); 9 = row-major
    /// xx,xy,xz,yx,yy,yz,zx,zy,zz. `None` for other counts.
    pub fn for_component_count(n: usize) -> Option<StressLayout> {
        use Component::*;
        let components = match n {
            3 => vec![Xx, Yy, Xy],
            4 => vec![Xx, Yy, Zz, Xy],
            6 => vec![Xx, Yy, Zz, Xy, Yz, Xz],
            9 => vec![Xx, Xy, Xz, Yx, Yy, Yz, Zx, Zy, Zz],
            _ => return None,
        };
        Some(StressLayout { components })
    }

    /// The components in array order.
    pub fn components(&self) -> &[Component] {
        &self.components
    }

    /// Number of components per value.
    pub fn len(&self) -> usize {
        self.components.len()
    }

    /// Always false (a layout has at least xx, yy, xy); for clippy's `len_without_is_empty`.
    pub fn is_empty(&self) -> bool {
        self.components.is_empty()
    }

    /// Position of component `c`, if present.
    pub fn index(&self, c: Component) -> Option<usize> {
        self.components.iter().position(|&k| k == c)
    }

    /// Position of σ_xx.
    pub fn xx(&self) -> usize {
        self.index(Component::Xx).expect("validated")
    }

    /// Position of σ_yy.
    pub fn yy(&self) -> usize {
        self.index(Component::Yy).expect("validated")
    }

    /// Position of σ_xy (of σ_yx when the layout only has yx).
    pub fn xy(&self) -> usize {
        self.index(Component::Xy)
            .or_else(|| self.index(Component::Yx))
            .expect("validated")
    }

    /// Position of σ_yx (of σ_xy in symmetric layouts without yx).
    pub fn yx(&self) -> usize {
        self.index(Component::Yx)
            .or_else(|| self.index(Component::Xy))
            .expect("validated")
    }

    /// Position of σ_zz, if present.
    pub fn zz(&self) -> Option<usize> {
        self.index(Component::Zz)
    }

    /// Whether the layout stores σ_xy and σ_yx separately (a full, possibly non-symmetric,
    /// tensor).
    pub fn has_yx(&self) -> bool {
        self.index(Component::Xy).is_some() && self.index(Component::Yx).is_some()
    }
}

impl fmt::Display for StressLayout {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let names: Vec<&str> = self.components.iter().map(|c| c.as_str()).collect();
        f.write_str(&names.join(","))
    }
}

/// `parent.key`, with the key quoted when it is not a bare TOML key.
pub(crate) fn join(parent: &str, key: &str) -> String {
    let bare = !key.is_empty()
        && key
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    let key = if bare {
        key.to_string()
    } else {
        format!("\"{}\"", key.escape_debug())
    };
    if parent.is_empty() {
        key
    } else {
        format!("{parent}.{key}")
    }
}

/// `boundary[2] "arc"`, or `boundary[2]` before the name is known.
pub(crate) fn label(index: usize, name: Option<&str>) -> String {
    match name {
        Some(name) => format!("boundary[{index}] \"{}\"", name.escape_debug()),
        None => format!("boundary[{index}]"),
    }
}
