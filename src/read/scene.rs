//! Scene file (TOML), docs/design.md §7: the physics that the VTU file does not hold.
//!
//! [`load_scene`] / [`parse_scene`] turn the file into validated plain structs ([`Scene`]).
//! Every problem is one [`Error::Input`] line `file: key path: problem`, where the key path
//! names the place in the file, e.g.
//!
//! ```text
//! scene.toml: boundary[2] "arc".where: unknown variable 'q'
//! scene.toml: material.colour: unknown key (accepted in [material]: youngs_modulus, poisson_ratio, model)
//! scene.toml: line 3, column 18: invalid TOML: string values must be quoted, expected literal string
//! ```
//!
//! `boundary[i]` counts the `[[boundary]]` tables from 0 in file order and is followed by the
//! boundary's name when it has one.
//!
//! # Keys
//!
//! The keys of docs/design.md §7, with these decisions where the design is silent:
//!
//! - `material.model` is optional, default `plane_strain`.
//! - `[boundaries] tag_array` is optional; a `tag` selector without it reads the cell-data
//!   array [`DEFAULT_TAG_ARRAY`] (`"boundary_tag"`, the name used in docs/design.md §7), see
//!   [`Scene::tag_array_name`]. Whether that array exists is checked against the mesh later.
//! - `displacement` (dirichlet) and `traction` (neumann) are required: a boundary that states
//!   a kind but no data is more likely a mistake than a default.
//! - `normal` (contact) is optional, default `body` (docs/design.md §2); `friction` default 0.
//! - Two boundaries with the same `tag` are an error (an edge would get two conditions);
//!   overlapping `where` selectors can only be detected on the mesh.
//! - ν = 0.5 forces the `robust` norm by default, and an explicit `energy` is refused
//!   (docs/design.md §3, §7), in plane stress too: there λ* = Eν/(1 − ν²) stays finite (see
//!   [`Material::lambda`]) and the energy norm would be defined, but one rule for ν = 0.5 keeps
//!   reports comparable across models and matches the reference harness.
//! - Numbers that must be finite (E, ν, friction, plane data, constant boundary data, ℓ) refuse
//!   TOML's `nan` and `inf`.
//! - Stress layouts are any comma-separated list of distinct components (see
//!   [`StressLayout`]), which includes the four layouts of docs/design.md §4.
//!
//! The model types live in [`crate::scene`] and are re-exported here.

use std::collections::HashMap;
use std::fmt;
use std::path::Path;

use toml::{Table, Value};

use crate::error::{Error, Result};
use crate::expr::Expr;

pub use crate::scene::*;
use crate::scene::{join, label};

// ---------------------------------------------------------------------------------------------
// Reading

/// Reads and validates the scene file at `path`.
pub fn load_scene(path: &Path) -> Result<Scene> {
    let bytes = crate::limits::read_bounded(
        path,
        crate::limits::MAX_SCENE_BYTES,
        "a scene file is TOML of a few kilobytes",
    )?;
    let text = String::from_utf8(bytes).map_err(|e| {
        Error::input(
            path,
            format!("byte {}", e.utf8_error().valid_up_to()),
            "not UTF-8 text (a scene file is TOML)",
        )
    })?;
    parse_scene(path, &text)
}

/// Validates the scene file `text`; `path` is only used to name the file in messages and is
/// stored in [`Scene::file`].
pub fn parse_scene(path: &Path, text: &str) -> Result<Scene> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let top: Table = text
        .parse()
        .map_err(|e: toml::de::Error| syntax_error(path, text, &e))?;
    let r = Reader { file: path };
    r.check_keys(
        &top,
        "",
        "at the top level",
        &[
            "material",
            "fields",
            "loads",
            "boundaries",
            "boundary",
            "estimate",
            "body",
        ],
    )?;

    let material = r.material(&top)?;
    let fields = match r.table(&top, "", "fields")? {
        Some(t) => r.fields(t)?,
        None => FieldNames::default(),
    };
    let body_force = match r.table(&top, "", "loads")? {
        Some(t) => {
            r.check_keys(t, "loads", "in [loads]", &["body_force"])?;
            match t.get("body_force") {
                Some(v) => Some(r.expr_pair(&join("loads", "body_force"), v)?),
                None => None,
            }
        }
        None => None,
    };
    let tag_array = match top.get("boundaries") {
        Some(Value::Array(_)) => {
            return Err(r.err(
                "boundaries",
                "expected a table [boundaries], found an array of tables \
                 (each boundary is a [[boundary]])",
            ));
        }
        _ => match r.table(&top, "", "boundaries")? {
            Some(t) => {
                r.check_keys(t, "boundaries", "in [boundaries]", &["tag_array"])?;
                r.name(t, "boundaries", "tag_array")?
            }
            None => None,
        },
    };
    let boundaries = r.boundaries(&top)?;
    let estimate = match r.table(&top, "", "estimate")? {
        Some(t) => r.estimate(t, &material)?,
        None => Estimate::default(),
    };
    let body = match r.table(&top, "", "body")? {
        Some(t) => Some(r.body(t)?),
        None => None,
    };
    Ok(Scene {
        file: path.to_path_buf(),
        material,
        fields,
        body_force,
        tag_array,
        boundaries,
        estimate,
        body,
    })
}

/// One line for a TOML syntax error: `line L, column C: invalid TOML: message`.
fn syntax_error(path: &Path, text: &str, e: &toml::de::Error) -> Error {
    let mut message = e.message().split_whitespace().collect::<Vec<_>>().join(" ");
    let Some(span) = e.span() else {
        return Error::input(path, "TOML", format!("invalid TOML: {message}"));
    };
    let start = span.start.min(text.len());
    let before = text.get(..start).unwrap_or(text);
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let column = before[line_start..].chars().count() + 1;
    if message == "duplicate key"
        && let Some(key) = text.get(span.clone()).filter(|k| !k.is_empty())
    {
        message = format!("duplicate key {}", key.escape_debug());
    }
    Error::input(
        path,
        format!("line {line}, column {column}"),
        format!("invalid TOML: {message}"),
    )
}

/// What a value is, for "expected …, found …".
fn describe(v: &Value) -> String {
    match v {
        Value::String(s) => {
            let short: String = s.chars().take(40).collect();
            let dots = if short.len() < s.len() { "…" } else { "" };
            format!("a string (\"{}{dots}\")", short.escape_debug())
        }
        Value::Integer(i) => format!("an integer ({i})"),
        Value::Float(f) => format!("a float ({f:?})"),
        Value::Boolean(b) => format!("a boolean ({b})"),
        Value::Datetime(d) => format!("a datetime ({d})"),
        Value::Array(a) => format!("an array of {} entries", a.len()),
        Value::Table(_) => "a table".to_string(),
    }
}

/// Validation helpers; every error names `file`.
struct Reader<'a> {
    file: &'a Path,
}

impl Reader<'_> {
    fn err(&self, place: impl fmt::Display, problem: impl fmt::Display) -> Error {
        Error::input(self.file, place, problem)
    }

    fn wrong_type(&self, place: &str, expected: &str, found: &Value) -> Error {
        self.err(
            place,
            format!("expected {expected}, found {}", describe(found)),
        )
    }

    fn missing(&self, place: &str) -> Error {
        self.err(place, "missing required key")
    }

    /// Refuses keys of `table` (at `path`) that are not in `accepted`.
    fn check_keys(&self, table: &Table, path: &str, scope: &str, accepted: &[&str]) -> Result<()> {
        match table.keys().find(|k| !accepted.contains(&k.as_str())) {
            Some(key) => Err(self.err(
                join(path, key),
                format!("unknown key (accepted {scope}: {})", accepted.join(", ")),
            )),
            None => Ok(()),
        }
    }

    /// The sub-table `key` of `table`, if present.
    fn table<'t>(&self, table: &'t Table, path: &str, key: &str) -> Result<Option<&'t Table>> {
        match table.get(key) {
            None => Ok(None),
            Some(Value::Table(t)) => Ok(Some(t)),
            Some(v) => Err(self.wrong_type(&join(path, key), "a table", v)),
        }
    }

    fn number(&self, table: &Table, path: &str, key: &str) -> Result<Option<f64>> {
        match table.get(key) {
            None => Ok(None),
            Some(v) => self.number_value(&join(path, key), v).map(Some),
        }
    }

    /// A number (integer or float), possibly not finite.
    fn number_value(&self, place: &str, v: &Value) -> Result<f64> {
        match v {
            Value::Integer(i) => Ok(*i as f64),
            Value::Float(f) => Ok(*f),
            _ => Err(self.wrong_type(place, "a number", v)),
        }
    }

    fn finite_value(&self, place: &str, v: &Value) -> Result<f64> {
        let x = self.number_value(place, v)?;
        if x.is_finite() {
            Ok(x)
        } else {
            Err(self.err(place, format!("must be a finite number, got {x:?}")))
        }
    }

    fn string<'t>(&self, table: &'t Table, path: &str, key: &str) -> Result<Option<&'t str>> {
        match table.get(key) {
            None => Ok(None),
            Some(Value::String(s)) => Ok(Some(s)),
            Some(v) => Err(self.wrong_type(&join(path, key), "a string", v)),
        }
    }

    /// A non-empty string (array or boundary name).
    fn name(&self, table: &Table, path: &str, key: &str) -> Result<Option<String>> {
        match self.string(table, path, key)? {
            Some("") => Err(self.err(join(path, key), "must not be empty")),
            Some(s) => Ok(Some(s.to_string())),
            None => Ok(None),
        }
    }

    /// One of `accepted` (scene spelling → value).
    fn choice<T: Copy>(
        &self,
        table: &Table,
        path: &str,
        key: &str,
        what: &str,
        accepted: &[(&str, T)],
    ) -> Result<Option<T>> {
        let Some(s) = self.string(table, path, key)? else {
            return Ok(None);
        };
        match accepted.iter().find(|(name, _)| *name == s) {
            Some((_, value)) => Ok(Some(*value)),
            None => {
                let names: Vec<&str> = accepted.iter().map(|(name, _)| *name).collect();
                Err(self.err(
                    join(path, key),
                    format!(
                        "unknown {what} \"{}\" (accepted: {})",
                        s.escape_debug(),
                        names.join(", ")
                    ),
                ))
            }
        }
    }

    /// A number, or a string with an expression in x, y.
    fn expr_value(&self, place: &str, v: &Value) -> Result<Expr> {
        match v {
            Value::String(s) => Expr::parse(s).map_err(|e| self.err(place, e)),
            Value::Integer(_) | Value::Float(_) => Ok(Expr::constant(self.finite_value(place, v)?)),
            _ => Err(self.wrong_type(place, "a number or a string with an expression in x, y", v)),
        }
    }

    /// `[a, b]`: exactly two entries.
    fn pair<'v>(&self, place: &str, v: &'v Value, entries: &str) -> Result<&'v [Value]> {
        match v {
            Value::Array(a) if a.len() == 2 => Ok(a.as_slice()),
            _ => Err(self.wrong_type(place, &format!("an array of 2 entries {entries}"), v)),
        }
    }

    /// `[number or expression, number or expression]`.
    fn expr_pair(&self, place: &str, v: &Value) -> Result<[Expr; 2]> {
        let a = self.pair(place, v, "[x, y] (numbers or expressions)")?;
        Ok([
            self.expr_value(&format!("{place}[0]"), &a[0])?,
            self.expr_value(&format!("{place}[1]"), &a[1])?,
        ])
    }

    /// `[number, number]`, finite.
    fn point(&self, place: &str, v: &Value) -> Result<[f64; 2]> {
        let a = self.pair(place, v, "[x, y]")?;
        Ok([
            self.finite_value(&format!("{place}[0]"), &a[0])?,
            self.finite_value(&format!("{place}[1]"), &a[1])?,
        ])
    }

    fn material(&self, top: &Table) -> Result<Material> {
        let Some(t) = self.table(top, "", "material")? else {
            return Err(self.err("material", "missing required table [material]"));
        };
        let path = "material";
        self.check_keys(
            t,
            path,
            "in [material]",
            &["youngs_modulus", "poisson_ratio", "model"],
        )?;
        let e_place = join(path, "youngs_modulus");
        let youngs_modulus = self
            .number(t, path, "youngs_modulus")?
            .ok_or_else(|| self.missing(&e_place))?;
        if !(youngs_modulus > 0.0 && youngs_modulus.is_finite()) {
            return Err(self.err(
                e_place,
                format!("must be a positive finite number, got {youngs_modulus:?}"),
            ));
        }
        let nu_place = join(path, "poisson_ratio");
        let poisson_ratio = self
            .number(t, path, "poisson_ratio")?
            .ok_or_else(|| self.missing(&nu_place))?;
        if !(poisson_ratio > -1.0 && poisson_ratio <= 0.5) {
            return Err(self.err(
                nu_place,
                format!("must lie in (-1, 0.5], got {poisson_ratio:?}"),
            ));
        }
        let model = self
            .choice(
                t,
                path,
                "model",
                "model",
                &[
                    ("plane_strain", Model::PlaneStrain),
                    ("plane_stress", Model::PlaneStress),
                ],
            )?
            .unwrap_or(Model::PlaneStrain);
        Ok(Material {
            youngs_modulus,
            poisson_ratio,
            model,
        })
    }

    /// `[body]`: exactly one of `index`, `cell_data = { name, value }`, `where`.
    fn body(&self, t: &Table) -> Result<BodySelector> {
        let path = "body";
        self.check_keys(t, path, "in [body]", &["index", "cell_data", "where"])?;
        let given: Vec<&str> = ["index", "cell_data", "where"]
            .into_iter()
            .filter(|k| t.contains_key(*k))
            .collect();
        match given.as_slice() {
            [] => Err(self.err(
                path,
                "empty table: give one of index = N, cell_data = { name, value }, where = \"…\"",
            )),
            [_] => Ok(()),
            [a, b, ..] => Err(self.err(
                path,
                format!("{a} and {b} are both given; give one body selector"),
            )),
        }?;
        if let Some(v) = t.get("index") {
            let place = join(path, "index");
            return match v {
                Value::Integer(i) if *i >= 0 => Ok(BodySelector::Index(*i as usize)),
                Value::Integer(i) => Err(self.err(place, format!("must be ≥ 0, got {i}"))),
                _ => Err(self.wrong_type(&place, "an integer", v)),
            };
        }
        if let Some(v) = t.get("cell_data") {
            let place = join(path, "cell_data");
            let Value::Table(c) = v else {
                return Err(self.wrong_type(&place, "a table { name, value }", v));
            };
            self.check_keys(c, &place, "in [body] cell_data", &["name", "value"])?;
            let name = self
                .name(c, &place, "name")?
                .ok_or_else(|| self.missing(&join(&place, "name")))?;
            let value = match c.get("value") {
                Some(v) => self.finite_value(&join(&place, "value"), v)?,
                None => return Err(self.missing(&join(&place, "value"))),
            };
            return Ok(BodySelector::CellData { name, value });
        }
        let place = join(path, "where");
        match t.get("where") {
            Some(Value::String(s)) => Expr::parse(s)
                .map(BodySelector::Where)
                .map_err(|e| self.err(place, e)),
            Some(v) => Err(self.wrong_type(&place, "a string with an expression in x, y", v)),
            None => unreachable!("one selector is given"),
        }
    }

    fn fields(&self, t: &Table) -> Result<FieldNames> {
        let path = "fields";
        self.check_keys(
            t,
            path,
            "in [fields]",
            &["displacement", "stress", "stress_layout"],
        )?;
        let stress_layout = match self.string(t, path, "stress_layout")? {
            Some(s) => {
                Some(StressLayout::parse(s).map_err(|e| self.err(join(path, "stress_layout"), e))?)
            }
            None => None,
        };
        let (displacement, displacement_parts) = self.names(t, path, "displacement", &[2, 3])?;
        let (stress, stress_parts) = self.names(t, path, "stress", &[3, 4, 6, 9])?;
        Ok(FieldNames {
            displacement,
            displacement_parts,
            stress,
            stress_parts,
            stress_layout,
        })
    }

    /// An array name, or a list of one-component arrays (`counts` entries) joined into one
    /// field ([`crate::read::components`]): the name to select and the parts (empty for one).
    fn names(
        &self,
        t: &Table,
        path: &str,
        key: &str,
        counts: &[usize],
    ) -> Result<(Option<String>, Vec<String>)> {
        let place = join(path, key);
        let Some(Value::Array(items)) = t.get(key) else {
            return Ok((self.name(t, path, key)?, Vec::new()));
        };
        let counts_text = counts
            .iter()
            .map(|c| c.to_string())
            .collect::<Vec<_>>()
            .join(" or ");
        if !counts.contains(&items.len()) {
            return Err(self.err(
                &place,
                format!(
                    "a list of component arrays needs {counts_text} names, found {}",
                    items.len()
                ),
            ));
        }
        let mut parts: Vec<String> = Vec::new();
        for (i, v) in items.iter().enumerate() {
            match v {
                Value::String(s) if s.is_empty() => {
                    return Err(self.err(format!("{place}[{i}]"), "must not be empty"));
                }
                Value::String(s) if parts.contains(s) => {
                    return Err(self.err(
                        format!("{place}[{i}]"),
                        format!("\"{}\" is listed twice", s.escape_debug()),
                    ));
                }
                Value::String(s) => parts.push(s.clone()),
                v => return Err(self.wrong_type(&format!("{place}[{i}]"), "a string", v)),
            }
        }
        Ok((Some(crate::read::components::joined_name(&parts)), parts))
    }

    fn estimate(&self, t: &Table, material: &Material) -> Result<Estimate> {
        let path = "estimate";
        self.check_keys(t, path, "in [estimate]", &["norm", "length_scale"])?;
        let norm = self.choice(
            t,
            path,
            "norm",
            "norm",
            &[
                ("energy", Norm::Energy),
                ("robust", Norm::Robust),
                ("seed", Norm::Seed),
            ],
        )?;
        if norm == Some(Norm::Energy) && material.is_incompressible() {
            return Err(self.err(
                join(path, "norm"),
                "ν = 0.5 needs norm = \"robust\" or \"seed\" \
                 (the energy norm is not uniform as λ → ∞)",
            ));
        }
        let length_scale = self.number(t, path, "length_scale")?;
        if let Some(l) = length_scale
            && !(l > 0.0 && l.is_finite())
        {
            return Err(self.err(
                join(path, "length_scale"),
                format!("must be a positive finite number, got {l:?}"),
            ));
        }
        Ok(Estimate { norm, length_scale })
    }

    fn boundaries(&self, top: &Table) -> Result<Vec<Boundary>> {
        let list = match top.get("boundary") {
            None => return Ok(Vec::new()),
            Some(Value::Array(a)) => a,
            Some(v @ Value::Table(_)) => {
                return Err(self.wrong_type(
                    "boundary",
                    "an array of tables (write [[boundary]], not [boundary])",
                    v,
                ));
            }
            Some(v) => return Err(self.wrong_type("boundary", "an array of tables", v)),
        };
        let mut boundaries: Vec<Boundary> = Vec::with_capacity(list.len());
        let mut by_name: HashMap<String, usize> = HashMap::new();
        let mut by_tag: HashMap<i64, usize> = HashMap::new();
        for (index, v) in list.iter().enumerate() {
            let Value::Table(t) = v else {
                return Err(self.wrong_type(&label(index, None), "a table", v));
            };
            let b = self.boundary(index, t)?;
            if let Some(&first) = by_name.get(&b.name) {
                return Err(self.err(
                    b.place("name"),
                    format!("duplicate boundary name (also {})", label(first, None)),
                ));
            }
            by_name.insert(b.name.clone(), index);
            if let Selector::Tag(tag) = b.selector {
                if let Some(&first) = by_tag.get(&tag) {
                    return Err(self.err(
                        b.place("tag"),
                        format!("tag {tag} is already used by {}", boundaries[first].label()),
                    ));
                }
                by_tag.insert(tag, index);
            }
            boundaries.push(b);
        }
        Ok(boundaries)
    }

    fn boundary(&self, index: usize, t: &Table) -> Result<Boundary> {
        let unnamed = label(index, None);
        let name = self
            .name(t, &unnamed, "name")?
            .ok_or_else(|| self.missing(&join(&unnamed, "name")))?;
        let path = label(index, Some(&name));
        const COMMON: [&str; 4] = ["name", "tag", "where", "kind"];
        const DIRICHLET: [&str; 1] = ["displacement"];
        const NEUMANN: [&str; 1] = ["traction"];
        const CONTACT: [&str; 4] = ["obstacle", "gap", "normal", "friction"];
        let all: Vec<&str> = [&COMMON[..], &DIRICHLET, &NEUMANN, &CONTACT].concat();
        self.check_keys(t, &path, "in [[boundary]]", &all)?;

        #[derive(Clone, Copy, PartialEq)]
        enum Kind {
            Dirichlet,
            Neumann,
            Contact,
        }
        let kind = self
            .choice(
                t,
                &path,
                "kind",
                "kind",
                &[
                    ("dirichlet", Kind::Dirichlet),
                    ("neumann", Kind::Neumann),
                    ("contact", Kind::Contact),
                ],
            )?
            .ok_or_else(|| {
                self.err(
                    join(&path, "kind"),
                    "missing required key (dirichlet, neumann or contact)",
                )
            })?;

        let selector = match (t.get("tag"), t.get("where")) {
            (Some(_), Some(_)) => {
                return Err(self.err(&path, "has both 'tag' and 'where': give one selector"));
            }
            (None, None) => {
                return Err(self.err(
                    &path,
                    "needs a selector: tag = <integer> or where = \"<expression in x, y>\"",
                ));
            }
            (Some(Value::Integer(tag)), None) => Selector::Tag(*tag),
            (Some(v), None) => return Err(self.wrong_type(&join(&path, "tag"), "an integer", v)),
            (None, Some(Value::String(s))) => {
                Selector::Where(Expr::parse(s).map_err(|e| self.err(join(&path, "where"), e))?)
            }
            (None, Some(v)) => {
                return Err(self.wrong_type(
                    &join(&path, "where"),
                    "a string with an expression in x, y (e.g. \"y > 0.999\")",
                    v,
                ));
            }
        };

        let (kind_name, own): (&str, &[&str]) = match kind {
            Kind::Dirichlet => ("dirichlet", &DIRICHLET),
            Kind::Neumann => ("neumann", &NEUMANN),
            Kind::Contact => ("contact", &CONTACT),
        };
        if let Some(key) = t
            .keys()
            .find(|k| !COMMON.contains(&k.as_str()) && !own.contains(&k.as_str()))
        {
            let takes = match kind {
                Kind::Contact => "obstacle or gap, normal, friction".to_string(),
                _ => own.join(", "),
            };
            return Err(self.err(
                join(&path, key),
                format!("not allowed on a {kind_name} boundary ({kind_name} takes: {takes})"),
            ));
        }
        let data = |key: &str| -> Result<[Expr; 2]> {
            let place = join(&path, key);
            match t.get(key) {
                Some(v) => self.expr_pair(&place, v),
                None => Err(self.err(
                    place,
                    format!("missing required key for a {kind_name} boundary"),
                )),
            }
        };
        let kind = match kind {
            Kind::Dirichlet => BoundaryKind::Dirichlet {
                displacement: data("displacement")?,
            },
            Kind::Neumann => BoundaryKind::Neumann {
                traction: data("traction")?,
            },
            Kind::Contact => BoundaryKind::Contact(self.contact(&path, t)?),
        };
        Ok(Boundary {
            index,
            name,
            selector,
            kind,
        })
    }

    fn contact(&self, path: &str, t: &Table) -> Result<Contact> {
        let gap = match (t.get("obstacle"), t.get("gap")) {
            (Some(_), Some(_)) => {
                return Err(self.err(path, "has both 'obstacle' and 'gap': give one"));
            }
            (None, None) => {
                return Err(self.err(
                    path,
                    "a contact boundary needs 'obstacle' (a rigid plane) or 'gap' (an expression)",
                ));
            }
            (Some(v), None) => self.obstacle(&join(path, "obstacle"), v)?,
            (None, Some(v)) => Gap::Expr(self.expr_value(&join(path, "gap"), v)?),
        };
        let normal = self
            .choice(
                t,
                path,
                "normal",
                "normal",
                &[
                    ("body", ContactNormal::Body),
                    ("obstacle", ContactNormal::Obstacle),
                ],
            )?
            .unwrap_or(ContactNormal::Body);
        if normal == ContactNormal::Obstacle && matches!(gap, Gap::Expr(_)) {
            return Err(self.err(
                join(path, "normal"),
                "normal = \"obstacle\" needs an obstacle to take the direction from; \
                 with 'gap' use normal = \"body\"",
            ));
        }
        let friction = match t.get("friction") {
            None => 0.0,
            Some(v) => {
                let place = join(path, "friction");
                let f = self.number_value(&place, v)?;
                if !(f >= 0.0 && f.is_finite()) {
                    return Err(self.err(place, format!("must be a finite number ≥ 0, got {f:?}")));
                }
                f
            }
        };
        Ok(Contact {
            gap,
            normal,
            friction,
        })
    }

    /// `obstacle = { plane = { point = [x, y], normal = [x, y] } }`.
    fn obstacle(&self, path: &str, v: &Value) -> Result<Gap> {
        let Value::Table(t) = v else {
            return Err(self.wrong_type(
                path,
                "a table like { plane = { point = [x, y], normal = [x, y] } }",
                v,
            ));
        };
        if let Some(key) = t.keys().find(|k| k.as_str() != "plane") {
            return Err(self.err(join(path, key), "unknown obstacle type (accepted: plane)"));
        }
        let Some(plane) = self.table(t, path, "plane")? else {
            return Err(self.err(
                path,
                "empty: give plane = { point = [x, y], normal = [x, y] }",
            ));
        };
        let path = join(path, "plane");
        self.check_keys(plane, &path, "in a plane obstacle", &["point", "normal"])?;
        let point_place = join(&path, "point");
        let point = match plane.get("point") {
            Some(v) => self.point(&point_place, v)?,
            None => return Err(self.missing(&point_place)),
        };
        let normal_place = join(&path, "normal");
        let m = match plane.get("normal") {
            Some(v) => self.point(&normal_place, v)?,
            None => return Err(self.missing(&normal_place)),
        };
        let length = m[0].hypot(m[1]);
        if !(length > 0.0 && length.is_finite()) {
            return Err(self.err(
                normal_place,
                "must be a nonzero vector (from the obstacle towards the body)",
            ));
        }
        Ok(Gap::Plane {
            point,
            normal: [m[0] / length, m[1] / length],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    /// The scene of docs/design.md §7, verbatim.
    const EXAMPLE: &str = r#"
[material]
youngs_modulus = 20600.0
poisson_ratio  = 0.28             # 0.5 allowed
model = "plane_strain"            # plane_strain | plane_stress   (3d later)

[fields]                          # optional; auto-detected when absent
displacement = "displacement"     # point-data array name
stress = "stress"                 # point- or cell-data array name; optional
stress_layout = "xx,yy,zz,xy"     # optional; inferred from the component count otherwise

[loads]                           # optional
body_force = [0.0, -1.0]          # numbers, or strings with expressions in x, y

[boundaries]
tag_array = "boundary_tag"        # cell-data array on the line cells of the file

[[boundary]]                      # select edges by `tag`, or by `where` = "expression in x, y"
name = "top"                      # (true where > 0), e.g. "y > 0.999"
tag = 2
kind = "dirichlet"
displacement = [0.0, -0.01]       # numbers or expressions

[[boundary]]
name = "sides"
where = "abs(x) > 0.999"
kind = "neumann"
traction = [0.0, 0.0]

[[boundary]]
name = "arc"
tag = 1
kind = "contact"
obstacle = { plane = { point = [0.0, 0.0], normal = [0.0, 1.0] } }  # rigid plane, normal into the gap
# gap = "expression in x, y"      # alternative to `obstacle`: g given directly
normal = "obstacle"               # body | obstacle: direction in which u_n and g are measured
friction = 0.4                    # optional, default 0

[estimate]                        # optional
norm = "energy"                   # energy | robust | seed
length_scale = 0.318              # ℓ in w_d = ℓ²/(2μ); default diameter(Ω)/π
"#;

    /// A minimal valid scene to which one test appends or in which it replaces a line.
    const MINIMAL: &str = r#"
[material]
youngs_modulus = 1.0
poisson_ratio = 0.3
"#;

    fn path() -> &'static Path {
        Path::new("scene.toml")
    }

    fn parse(text: &str) -> Result<Scene> {
        parse_scene(path(), text)
    }

    fn c(v: f64) -> Expr {
        Expr::constant(v)
    }

    /// The full one-line message for `text`, which must be refused.
    fn error(text: &str) -> String {
        match parse(text) {
            Ok(scene) => panic!("accepted: {scene:?}"),
            Err(e) => {
                let message = e.to_string();
                assert!(!message.contains('\n'), "not one line: {message}");
                message
            }
        }
    }

    /// Error for MINIMAL followed by `extra`.
    fn error_with(extra: &str) -> String {
        error(&format!("{MINIMAL}{extra}"))
    }

    fn scene_with(extra: &str) -> Scene {
        parse(&format!("{MINIMAL}{extra}")).unwrap_or_else(|e| panic!("{e}"))
    }

    fn boundary(b: &str) -> String {
        format!("[[boundary]]\nname = \"b\"\n{b}\n")
    }

    #[test]
    #[allow(clippy::approx_constant)] // 0.318 is the value written in docs/design.md §7
    fn design_example_parses_to_the_expected_values() {
        let scene = parse(EXAMPLE).unwrap();
        let expected = Scene {
            file: PathBuf::from("scene.toml"),
            material: Material {
                youngs_modulus: 20600.0,
                poisson_ratio: 0.28,
                model: Model::PlaneStrain,
            },
            fields: FieldNames {
                displacement: Some("displacement".into()),
                stress: Some("stress".into()),
                stress_layout: Some(StressLayout::for_component_count(4).unwrap()),
                ..Default::default()
            },
            body_force: Some([c(0.0), c(-1.0)]),
            tag_array: Some("boundary_tag".into()),
            boundaries: vec![
                Boundary {
                    index: 0,
                    name: "top".into(),
                    selector: Selector::Tag(2),
                    kind: BoundaryKind::Dirichlet {
                        displacement: [c(0.0), c(-0.01)],
                    },
                },
                Boundary {
                    index: 1,
                    name: "sides".into(),
                    selector: Selector::Where(Expr::parse("abs(x) > 0.999").unwrap()),
                    kind: BoundaryKind::Neumann {
                        traction: [c(0.0), c(0.0)],
                    },
                },
                Boundary {
                    index: 2,
                    name: "arc".into(),
                    selector: Selector::Tag(1),
                    kind: BoundaryKind::Contact(Contact {
                        gap: Gap::Plane {
                            point: [0.0, 0.0],
                            normal: [0.0, 1.0],
                        },
                        normal: ContactNormal::Obstacle,
                        friction: 0.4,
                    }),
                },
            ],
            estimate: Estimate {
                norm: Some(Norm::Energy),
                length_scale: Some(0.318),
            },
            body: None,
        };
        assert_eq!(scene, expected);
        assert_eq!(scene.effective_norm(), Norm::Energy);
        assert_eq!(scene.tag_array_name(), Some("boundary_tag"));
        let layout = scene.fields.stress_layout.as_ref().unwrap();
        assert_eq!(
            (layout.xx(), layout.yy(), layout.xy(), layout.zz()),
            (0, 1, 3, Some(2))
        );
        assert_eq!(
            scene.boundaries[2].place("normal"),
            "boundary[2] \"arc\".normal"
        );
        assert_eq!(scene.boundaries[1].selector.key(), "where");
        assert!(scene.boundaries[1].selector_holds_example());
        // Contact frame of the §7 plane y = 0 with normal = "obstacle": n = (0, −1) and
        // g = y, so u_n ≤ g reads u_y ≥ −y.
        let contact = scene.boundaries[2].contact().unwrap();
        let n = contact.direction([0.6, -0.8]);
        assert_eq!(n, [-0.0, -1.0]);
        assert_eq!(contact.gap_at([0.3, 0.25], n), 0.25);
    }

    impl Boundary {
        fn selector_holds_example(&self) -> bool {
            match &self.selector {
                Selector::Where(e) => e.holds(1.0, 0.5, 0.0) && !e.holds(0.5, 0.5, 0.0),
                Selector::Tag(_) => false,
            }
        }
    }

    #[test]
    fn minimal_scene_and_defaults() {
        let scene = parse(MINIMAL).unwrap();
        assert_eq!(scene.material.model, Model::PlaneStrain);
        assert_eq!(scene.fields, FieldNames::default());
        assert_eq!(scene.body_force, None);
        assert_eq!(scene.tag_array, None);
        assert_eq!(scene.tag_array_name(), None);
        assert!(scene.boundaries.is_empty());
        assert_eq!(scene.estimate, Estimate::default());
        assert_eq!(scene.effective_norm(), Norm::Energy);
    }

    #[test]
    fn expressions_and_numbers_mix() {
        let scene = scene_with(
            r#"
[loads]
body_force = ["0", "-9.81*(1 + 0*x)"]
[[boundary]]
name = "top"
where = "y > 0.999"
kind = "dirichlet"
displacement = [0, "-0.01*x"]
[[boundary]]
name = "arc"
tag = -3
kind = "contact"
gap = "x^2/2"
"#,
        );
        let f = scene.body_force.as_ref().unwrap();
        assert!(f[0].is_constant());
        assert_eq!(f[1].eval(5.0, 0.0, 0.0), -9.81);
        assert!(!f[1].is_constant());
        let BoundaryKind::Dirichlet { displacement } = &scene.boundaries[0].kind else {
            panic!()
        };
        assert_eq!(displacement[0], c(0.0));
        assert_eq!(displacement[1].eval(2.0, 0.0, 0.0), -0.02);
        let contact = scene.boundaries[1].contact().unwrap();
        assert_eq!(contact.normal, ContactNormal::Body);
        assert_eq!(contact.friction, 0.0);
        assert_eq!(contact.gap_at([3.0, 1.0], [0.0, -1.0]), 4.5);
        assert_eq!(scene.boundaries[1].selector, Selector::Tag(-3));
        // A tag selector without [boundaries] tag_array reads the default array.
        assert_eq!(scene.tag_array_name(), Some(DEFAULT_TAG_ARRAY));
    }

    #[test]
    fn plane_obstacle_is_normalised_and_measured_along_the_body_normal() {
        let scene = scene_with(&boundary(
            "tag = 1\nkind = \"contact\"\n\
             obstacle = { plane = { point = [0, -1], normal = [0, 2] } }",
        ));
        let contact = scene.boundaries[0].contact().unwrap();
        assert_eq!(
            contact.gap,
            Gap::Plane {
                point: [0.0, -1.0],
                normal: [0.0, 1.0]
            }
        );
        // normal = "body": along n_Ω = (0.6, −0.8) from (0, 0), the plane y = −1 is at
        // distance 1/0.8.
        let n = contact.direction([0.6, -0.8]);
        assert_eq!(n, [0.6, -0.8]);
        assert!((contact.gap_at([0.0, 0.0], n) - 1.25).abs() < 1e-15);
        // Moving away from the plane never meets it.
        assert_eq!(contact.gap_at([0.0, 0.0], [0.0, 1.0]), f64::INFINITY);
    }

    /// E = 20600, ν = 0.28 by hand:
    /// μ = 20600/(2·1.28) = 20600/2.56 = 8046.875;
    /// λ = 20600·0.28/(1.28·0.44) = 5768/0.5632 = 450625/44 = 10241.477272…;
    /// plane stress λ* = Eν/(1−ν²) = 5768/0.9216 = 450625/72 = 6258.680555…,
    /// equal to 2λμ/(λ+2μ).
    #[test]
    fn lame_parameters_against_hand_values() {
        let mut m = Material {
            youngs_modulus: 20600.0,
            poisson_ratio: 0.28,
            model: Model::PlaneStrain,
        };
        let close = |a: f64, b: f64| assert!((a - b).abs() <= 1e-12 * b.abs(), "{a} != {b}");
        close(m.mu(), 8046.875);
        close(m.lame_lambda(), 450625.0 / 44.0);
        close(m.lambda(), 450625.0 / 44.0);
        assert!(!m.is_incompressible());
        m.model = Model::PlaneStress;
        close(m.lambda(), 450625.0 / 72.0);
        let (l, mu) = (m.lame_lambda(), m.mu());
        close(m.lambda(), 2.0 * l * mu / (l + 2.0 * mu));
    }

    /// ν = 0.5: plane strain λ = ∞; plane stress λ* = Eν/(1−ν²) = 2E/3 = 2μ (E = 3: μ = 1,
    /// λ* = 2).
    #[test]
    fn incompressible_material() {
        let mut m = Material {
            youngs_modulus: 3.0,
            poisson_ratio: 0.5,
            model: Model::PlaneStrain,
        };
        assert_eq!(m.mu(), 1.0);
        assert_eq!(m.lame_lambda(), f64::INFINITY);
        assert_eq!(m.lambda(), f64::INFINITY);
        assert!(m.is_incompressible());
        m.model = Model::PlaneStress;
        assert_eq!(m.lambda(), 2.0);
        assert_eq!(m.lame_lambda(), f64::INFINITY);
        assert!(m.is_incompressible());
    }

    #[test]
    fn norm_defaults_and_forcing() {
        let incompressible = "[material]\nyoungs_modulus = 1\npoisson_ratio = 0.5\n";
        let scene = parse(incompressible).unwrap();
        assert_eq!(scene.effective_norm(), Norm::Robust);
        let seed = parse(&format!("{incompressible}[estimate]\nnorm = \"seed\"\n")).unwrap();
        assert_eq!(seed.effective_norm(), Norm::Seed);
        let robust = scene_with("[estimate]\nnorm = \"robust\"\n");
        assert_eq!(robust.effective_norm(), Norm::Robust);
        // ν = 0.5 forces robust in plane stress too (docs/design.md §3, §7).
        let stress = format!("{incompressible}model = \"plane_stress\"\n");
        assert_eq!(parse(&stress).unwrap().effective_norm(), Norm::Robust);
        let explicit = format!("{stress}[estimate]\nnorm = \"energy\"\n");
        assert!(parse(&explicit).is_err());
    }

    #[test]
    fn stress_layouts() {
        let l = StressLayout::parse("xx,yy,xy").unwrap();
        assert_eq!(
            (l.len(), l.xx(), l.yy(), l.xy(), l.yx(), l.zz()),
            (3, 0, 1, 2, 2, None)
        );
        assert_eq!(l, StressLayout::for_component_count(3).unwrap());
        let l = StressLayout::parse(" XX, YY, ZZ, XY ").unwrap();
        assert_eq!(
            (l.len(), l.xx(), l.yy(), l.xy(), l.zz()),
            (4, 0, 1, 3, Some(2))
        );
        assert_eq!(l, StressLayout::for_component_count(4).unwrap());
        let l = StressLayout::parse("xx,yy,zz,xy,yz,xz").unwrap();
        assert_eq!(
            (l.len(), l.xx(), l.yy(), l.xy(), l.zz()),
            (6, 0, 1, 3, Some(2))
        );
        assert!(!l.has_yx());
        assert_eq!(l, StressLayout::for_component_count(6).unwrap());
        let l = StressLayout::parse("Xx,xY,xz,yx,yy,yz,zx,zy,zz").unwrap();
        assert_eq!((l.len(), l.xx(), l.yy(), l.xy(), l.yx()), (9, 0, 4, 1, 3));
        assert!(l.has_yx());
        assert_eq!(l, StressLayout::for_component_count(9).unwrap());
        assert_eq!(l.to_string(), "xx,xy,xz,yx,yy,yz,zx,zy,zz");
        assert_eq!(StressLayout::for_component_count(5), None);
        let err = |s: &str| StressLayout::parse(s).unwrap_err();
        assert_eq!(err(""), "empty layout: give components like \"xx,yy,xy\"");
        assert_eq!(err("xx,,yy"), "component 2 is empty");
        assert_eq!(
            err("xx,yy,ab"),
            "unknown component 'ab' (components: xx, yy, zz, xy, yx, xz, zx, yz, zy)"
        );
        assert_eq!(err("xx,yy,xx,xy"), "component 'xx' appears twice");
        assert_eq!(err("xx,xy"), "component 'yy' is missing");
        assert_eq!(err("xx,yy,zz"), "component 'xy' (or 'yx') is missing");
    }

    #[test]
    fn syntax_errors_are_one_line_with_position() {
        assert_eq!(
            error("[material]\nyoungs_modulus = \n"),
            "scene.toml: line 2, column 18: invalid TOML: \
             string values must be quoted, expected literal string"
        );
        assert_eq!(
            error("[material]\nyoungs_modulus = 1\nyoungs_modulus = 2\n"),
            "scene.toml: line 3, column 1: invalid TOML: duplicate key youngs_modulus"
        );
        assert_eq!(
            error("x = [1, 2"),
            "scene.toml: line 1, column 10: invalid TOML: unclosed array, expected `]`"
        );
    }

    #[test]
    fn unknown_keys() {
        assert_eq!(
            error(&format!("colour = 1\n{MINIMAL}")),
            "scene.toml: colour: unknown key (accepted at the top level: \
             material, fields, loads, boundaries, boundary, estimate, body)"
        );
        assert_eq!(
            error_with("[materials]\n"),
            "scene.toml: materials: unknown key (accepted at the top level: \
             material, fields, loads, boundaries, boundary, estimate, body)"
        );
        assert_eq!(
            error(&format!("{MINIMAL}density = 7.8\n")),
            "scene.toml: material.density: unknown key \
             (accepted in [material]: youngs_modulus, poisson_ratio, model)"
        );
        assert_eq!(
            error_with("[fields]\ntemperature = \"T\"\n"),
            "scene.toml: fields.temperature: unknown key \
             (accepted in [fields]: displacement, stress, stress_layout)"
        );
        assert_eq!(
            error_with("[loads]\ngravity = 1\n"),
            "scene.toml: loads.gravity: unknown key (accepted in [loads]: body_force)"
        );
        assert_eq!(
            error_with("[boundaries]\ntags = \"t\"\n"),
            "scene.toml: boundaries.tags: unknown key (accepted in [boundaries]: tag_array)"
        );
        assert_eq!(
            error_with("[estimate]\ndegree = 1\n"),
            "scene.toml: estimate.degree: unknown key \
             (accepted in [estimate]: norm, length_scale)"
        );
        assert_eq!(
            error_with(&boundary("tag = 1\nkind = \"neumann\"\ntraktion = [0, 0]")),
            "scene.toml: boundary[0] \"b\".traktion: unknown key (accepted in [[boundary]]: \
             name, tag, where, kind, displacement, traction, obstacle, gap, normal, friction)"
        );
        assert_eq!(
            error_with(&boundary(
                "tag = 1\nkind = \"contact\"\n\
                 obstacle = { plane = { point = [0, 0], normal = [0, 1], offset = 1 } }"
            )),
            "scene.toml: boundary[0] \"b\".obstacle.plane.offset: unknown key \
             (accepted in a plane obstacle: point, normal)"
        );
        assert_eq!(
            error_with(&boundary(
                "tag = 1\nkind = \"contact\"\nobstacle = { sphere = { radius = 1 } }"
            )),
            "scene.toml: boundary[0] \"b\".obstacle.sphere: unknown obstacle type \
             (accepted: plane)"
        );
        // Keys that are not bare are quoted, so the message stays one line.
        assert_eq!(
            error(&format!("\"a\\nb\" = 1\n{MINIMAL}")),
            "scene.toml: \"a\\nb\": unknown key (accepted at the top level: \
             material, fields, loads, boundaries, boundary, estimate, body)"
        );
    }

    #[test]
    fn body_selectors_and_their_errors() {
        assert_eq!(
            scene_with("[body]\nindex = 1\n").body,
            Some(BodySelector::Index(1))
        );
        assert_eq!(
            scene_with("[body]\ncell_data = { name = \"mat\", value = 2 }\n").body,
            Some(BodySelector::CellData {
                name: "mat".into(),
                value: 2.0
            })
        );
        let Some(BodySelector::Where(e)) = scene_with("[body]\nwhere = \"y > 0\"\n").body else {
            panic!("a where selector")
        };
        assert!(e.holds(0.0, 1.0, 0.0) && !e.holds(0.0, -1.0, 0.0));
        assert_eq!(scene_with("").body, None);
        assert_eq!(
            error_with("[body]\nindex = 0\nwhere = \"y > 0\"\n"),
            "scene.toml: body: index and where are both given; give one body selector"
        );
        assert_eq!(
            error_with("[body]\n"),
            "scene.toml: body: empty table: give one of index = N, cell_data = { name, value }, \
             where = \"…\""
        );
        assert_eq!(
            error_with("[body]\nnumber = 0\n"),
            "scene.toml: body.number: unknown key (accepted in [body]: index, cell_data, where)"
        );
        assert_eq!(
            error_with("[body]\nindex = -1\n"),
            "scene.toml: body.index: must be ≥ 0, got -1"
        );
        assert_eq!(
            error_with("[body]\nindex = 1.5\n"),
            "scene.toml: body.index: expected an integer, found a float (1.5)"
        );
        assert_eq!(
            error_with("[body]\ncell_data = { name = \"mat\" }\n"),
            "scene.toml: body.cell_data.value: missing required key"
        );
        assert_eq!(
            error_with("[body]\nwhere = \"q > 0\"\n"),
            "scene.toml: body.where: unknown variable 'q'"
        );
    }

    #[test]
    fn missing_keys() {
        assert_eq!(
            error("[fields]\nstress = \"s\"\n"),
            "scene.toml: material: missing required table [material]"
        );
        assert_eq!(
            error("[material]\npoisson_ratio = 0.3\n"),
            "scene.toml: material.youngs_modulus: missing required key"
        );
        assert_eq!(
            error("[material]\nyoungs_modulus = 1\n"),
            "scene.toml: material.poisson_ratio: missing required key"
        );
        assert_eq!(
            error_with("[[boundary]]\ntag = 1\nkind = \"neumann\"\ntraction = [0, 0]\n"),
            "scene.toml: boundary[0].name: missing required key"
        );
        assert_eq!(
            error_with(&boundary("tag = 1\ntraction = [0, 0]")),
            "scene.toml: boundary[0] \"b\".kind: missing required key \
             (dirichlet, neumann or contact)"
        );
        assert_eq!(
            error_with(&boundary("tag = 1\nkind = \"dirichlet\"")),
            "scene.toml: boundary[0] \"b\".displacement: \
             missing required key for a dirichlet boundary"
        );
        assert_eq!(
            error_with(&boundary("tag = 1\nkind = \"neumann\"")),
            "scene.toml: boundary[0] \"b\".traction: missing required key for a neumann boundary"
        );
        assert_eq!(
            error_with(&boundary(
                "tag = 1\nkind = \"contact\"\nobstacle = { plane = { point = [0, 0] } }"
            )),
            "scene.toml: boundary[0] \"b\".obstacle.plane.normal: missing required key"
        );
        assert_eq!(
            error_with(&boundary(
                "tag = 1\nkind = \"contact\"\nobstacle = { plane = { normal = [0, 1] } }"
            )),
            "scene.toml: boundary[0] \"b\".obstacle.plane.point: missing required key"
        );
        assert_eq!(
            error_with(&boundary("tag = 1\nkind = \"contact\"\nobstacle = {}")),
            "scene.toml: boundary[0] \"b\".obstacle: \
             empty: give plane = { point = [x, y], normal = [x, y] }"
        );
    }

    #[test]
    fn wrong_types() {
        assert_eq!(
            error("[material]\nyoungs_modulus = \"steel\"\npoisson_ratio = 0.3\n"),
            "scene.toml: material.youngs_modulus: expected a number, found a string (\"steel\")"
        );
        assert_eq!(
            error("material = 1\n"),
            "scene.toml: material: expected a table, found an integer (1)"
        );
        assert_eq!(
            error(&format!("{MINIMAL}model = 2\n")),
            "scene.toml: material.model: expected a string, found an integer (2)"
        );
        assert_eq!(
            error_with("[fields]\ndisplacement = [\"u\"]\n"),
            "scene.toml: fields.displacement: a list of component arrays needs 2 or 3 names, \
             found 1"
        );
        assert_eq!(
            error_with("[fields]\nstress = \"\"\n"),
            "scene.toml: fields.stress: must not be empty"
        );
        assert_eq!(
            error_with("[fields]\nstress = [\"a\", \"b\"]\n"),
            "scene.toml: fields.stress: a list of component arrays needs 3 or 4 or 6 or 9 names, \
             found 2"
        );
        assert_eq!(
            error_with("[fields]\ndisplacement = [\"a\", \"a\"]\n"),
            "scene.toml: fields.displacement[1]: \"a\" is listed twice"
        );
        assert_eq!(
            error_with("[fields]\ndisplacement = [\"a\", \"\"]\n"),
            "scene.toml: fields.displacement[1]: must not be empty"
        );
        assert_eq!(
            error_with("[fields]\ndisplacement = [\"a\", 2]\n"),
            "scene.toml: fields.displacement[1]: expected a string, found an integer (2)"
        );
        assert_eq!(
            error_with("[loads]\nbody_force = [0, 1, 2]\n"),
            "scene.toml: loads.body_force: expected an array of 2 entries [x, y] \
             (numbers or expressions), found an array of 3 entries"
        );
        assert_eq!(
            error_with("[loads]\nbody_force = [0, true]\n"),
            "scene.toml: loads.body_force[1]: expected a number or a string with an \
             expression in x, y, found a boolean (true)"
        );
        assert_eq!(
            error_with("[loads]\nbody_force = [0, nan]\n"),
            "scene.toml: loads.body_force[1]: must be a finite number, got NaN"
        );
        assert_eq!(
            error_with("[boundaries]\ntag_array = 3\n"),
            "scene.toml: boundaries.tag_array: expected a string, found an integer (3)"
        );
        assert_eq!(
            error_with("[[boundaries]]\ntag_array = \"t\"\n"),
            "scene.toml: boundaries: expected a table [boundaries], found an array of tables \
             (each boundary is a [[boundary]])"
        );
        assert_eq!(
            error_with("[boundary]\nname = \"b\"\n"),
            "scene.toml: boundary: expected an array of tables \
             (write [[boundary]], not [boundary]), found a table"
        );
        assert_eq!(
            error(&format!("boundary = [1]\n{MINIMAL}")),
            "scene.toml: boundary[0]: expected a table, found an integer (1)"
        );
        assert_eq!(
            error_with(&boundary(
                "tag = \"2\"\nkind = \"neumann\"\ntraction = [0, 0]"
            )),
            "scene.toml: boundary[0] \"b\".tag: expected an integer, found a string (\"2\")"
        );
        assert_eq!(
            error_with(&boundary(
                "tag = 2.0\nkind = \"neumann\"\ntraction = [0, 0]"
            )),
            "scene.toml: boundary[0] \"b\".tag: expected an integer, found a float (2.0)"
        );
        assert_eq!(
            error_with(&boundary(
                "where = 1\nkind = \"neumann\"\ntraction = [0, 0]"
            )),
            "scene.toml: boundary[0] \"b\".where: expected a string with an expression in \
             x, y (e.g. \"y > 0.999\"), found an integer (1)"
        );
        assert_eq!(
            error_with(&boundary("tag = 1\nkind = \"dirichlet\"\ndisplacement = 0")),
            "scene.toml: boundary[0] \"b\".displacement: expected an array of 2 entries \
             [x, y] (numbers or expressions), found an integer (0)"
        );
        assert_eq!(
            error_with(&boundary(
                "tag = 1\nkind = \"contact\"\nobstacle = { plane = { point = [0], normal = [0, 1] } }"
            )),
            "scene.toml: boundary[0] \"b\".obstacle.plane.point: expected an array of 2 \
             entries [x, y], found an array of 1 entries"
        );
        assert_eq!(
            error_with(&boundary(
                "tag = 1\nkind = \"contact\"\nobstacle = { plane = { point = [0, \"y\"], normal = [0, 1] } }"
            )),
            "scene.toml: boundary[0] \"b\".obstacle.plane.point[1]: expected a number, \
             found a string (\"y\")"
        );
        assert_eq!(
            error_with(&boundary(
                "tag = 1\nkind = \"contact\"\nobstacle = \"floor\""
            )),
            "scene.toml: boundary[0] \"b\".obstacle: expected a table like \
             { plane = { point = [x, y], normal = [x, y] } }, found a string (\"floor\")"
        );
        assert_eq!(
            error_with(&boundary(
                "tag = 1\nkind = \"contact\"\ngap = 0\nfriction = \"0.3\""
            )),
            "scene.toml: boundary[0] \"b\".friction: expected a number, found a string (\"0.3\")"
        );
        assert_eq!(
            error_with("[[boundary]]\nname = 7\n"),
            "scene.toml: boundary[0].name: expected a string, found an integer (7)"
        );
    }

    #[test]
    fn material_values() {
        let m = |e: &str, nu: &str| {
            error(&format!(
                "[material]\nyoungs_modulus = {e}\npoisson_ratio = {nu}\n"
            ))
        };
        assert_eq!(
            m("0", "0.3"),
            "scene.toml: material.youngs_modulus: must be a positive finite number, got 0.0"
        );
        assert_eq!(
            m("-2.5", "0.3"),
            "scene.toml: material.youngs_modulus: must be a positive finite number, got -2.5"
        );
        assert_eq!(
            m("inf", "0.3"),
            "scene.toml: material.youngs_modulus: must be a positive finite number, got inf"
        );
        assert_eq!(
            m("nan", "0.3"),
            "scene.toml: material.youngs_modulus: must be a positive finite number, got NaN"
        );
        assert_eq!(
            m("1", "0.50001"),
            "scene.toml: material.poisson_ratio: must lie in (-1, 0.5], got 0.50001"
        );
        assert_eq!(
            m("1", "-1"),
            "scene.toml: material.poisson_ratio: must lie in (-1, 0.5], got -1.0"
        );
        assert_eq!(
            m("1", "nan"),
            "scene.toml: material.poisson_ratio: must lie in (-1, 0.5], got NaN"
        );
        assert!(parse("[material]\nyoungs_modulus = 1e12\npoisson_ratio = -0.99\n").is_ok());
        assert!(parse("[material]\nyoungs_modulus = 1e-3\npoisson_ratio = 0.4999999\n").is_ok());
        assert_eq!(
            error(&format!("{MINIMAL}model = \"3d\"\n")),
            "scene.toml: material.model: unknown model \"3d\" \
             (accepted: plane_strain, plane_stress)"
        );
        assert_eq!(
            error(
                "[material]\nyoungs_modulus = 1\npoisson_ratio = 0.5\n\
                 [estimate]\nnorm = \"energy\"\n"
            ),
            "scene.toml: estimate.norm: ν = 0.5 needs norm = \"robust\" or \"seed\" \
             (the energy norm is not uniform as λ → ∞)"
        );
    }

    #[test]
    fn estimate_values() {
        assert_eq!(
            error_with("[estimate]\nnorm = \"L2\"\n"),
            "scene.toml: estimate.norm: unknown norm \"L2\" (accepted: energy, robust, seed)"
        );
        assert_eq!(
            error_with("[estimate]\nlength_scale = 0\n"),
            "scene.toml: estimate.length_scale: must be a positive finite number, got 0.0"
        );
        assert_eq!(
            error_with("[estimate]\nlength_scale = -1.5\n"),
            "scene.toml: estimate.length_scale: must be a positive finite number, got -1.5"
        );
        assert_eq!(
            error_with("[estimate]\nlength_scale = inf\n"),
            "scene.toml: estimate.length_scale: must be a positive finite number, got inf"
        );
        assert_eq!(
            scene_with("[estimate]\nlength_scale = 2\n")
                .estimate
                .length_scale,
            Some(2.0)
        );
    }

    #[test]
    fn boundary_rules() {
        assert_eq!(
            error_with(&boundary("kind = \"sliding\"\ntag = 1")),
            "scene.toml: boundary[0] \"b\".kind: unknown kind \"sliding\" \
             (accepted: dirichlet, neumann, contact)"
        );
        assert_eq!(
            error_with(&boundary(
                "tag = 1\nwhere = \"y > 0\"\nkind = \"neumann\"\ntraction = [0, 0]"
            )),
            "scene.toml: boundary[0] \"b\": has both 'tag' and 'where': give one selector"
        );
        assert_eq!(
            error_with(&boundary("kind = \"neumann\"\ntraction = [0, 0]")),
            "scene.toml: boundary[0] \"b\": needs a selector: \
             tag = <integer> or where = \"<expression in x, y>\""
        );
        assert_eq!(
            error_with(&boundary(
                "tag = 1\nkind = \"dirichlet\"\ndisplacement = [0, 0]\ntraction = [0, 0]"
            )),
            "scene.toml: boundary[0] \"b\".traction: not allowed on a dirichlet boundary \
             (dirichlet takes: displacement)"
        );
        assert_eq!(
            error_with(&boundary(
                "tag = 1\nkind = \"neumann\"\ntraction = [0, 0]\nfriction = 0.3"
            )),
            "scene.toml: boundary[0] \"b\".friction: not allowed on a neumann boundary \
             (neumann takes: traction)"
        );
        assert_eq!(
            error_with(&boundary(
                "tag = 1\nkind = \"contact\"\ngap = 0\ntraction = [0, 0]"
            )),
            "scene.toml: boundary[0] \"b\".traction: not allowed on a contact boundary \
             (contact takes: obstacle or gap, normal, friction)"
        );
        assert_eq!(
            error_with(&boundary(
                "tag = 1\nkind = \"contact\"\ngap = 0\n\
                 obstacle = { plane = { point = [0, 0], normal = [0, 1] } }"
            )),
            "scene.toml: boundary[0] \"b\": has both 'obstacle' and 'gap': give one"
        );
        assert_eq!(
            error_with(&boundary("tag = 1\nkind = \"contact\"")),
            "scene.toml: boundary[0] \"b\": a contact boundary needs 'obstacle' \
             (a rigid plane) or 'gap' (an expression)"
        );
        assert_eq!(
            error_with(&boundary(
                "tag = 1\nkind = \"contact\"\n\
                 obstacle = { plane = { point = [0, 0], normal = [0, 0] } }"
            )),
            "scene.toml: boundary[0] \"b\".obstacle.plane.normal: must be a nonzero vector \
             (from the obstacle towards the body)"
        );
        assert_eq!(
            error_with(&boundary(
                "tag = 1\nkind = \"contact\"\ngap = 0\nfriction = -0.1"
            )),
            "scene.toml: boundary[0] \"b\".friction: must be a finite number ≥ 0, got -0.1"
        );
        assert_eq!(
            error_with(&boundary(
                "tag = 1\nkind = \"contact\"\ngap = 0\nfriction = inf"
            )),
            "scene.toml: boundary[0] \"b\".friction: must be a finite number ≥ 0, got inf"
        );
        assert_eq!(
            error_with(&boundary(
                "tag = 1\nkind = \"contact\"\ngap = 0\nnormal = \"outward\""
            )),
            "scene.toml: boundary[0] \"b\".normal: unknown normal \"outward\" \
             (accepted: body, obstacle)"
        );
        assert_eq!(
            error_with(&boundary(
                "tag = 1\nkind = \"contact\"\ngap = \"0.1 - x^2\"\nnormal = \"obstacle\""
            )),
            "scene.toml: boundary[0] \"b\".normal: normal = \"obstacle\" needs an obstacle \
             to take the direction from; with 'gap' use normal = \"body\""
        );
        assert_eq!(
            error_with("[[boundary]]\nname = \"\"\n"),
            "scene.toml: boundary[0].name: must not be empty"
        );
        let two = "[[boundary]]\nname = \"top\"\ntag = 1\nkind = \"neumann\"\ntraction = [0, 0]\n\
                   [[boundary]]\nname = \"top\"\ntag = 2\nkind = \"neumann\"\ntraction = [0, 0]\n";
        assert_eq!(
            error_with(two),
            "scene.toml: boundary[1] \"top\".name: duplicate boundary name (also boundary[0])"
        );
        let same_tag = "[[boundary]]\nname = \"a\"\ntag = 1\nkind = \"neumann\"\ntraction = [0, 0]\n\
                        [[boundary]]\nname = \"b\"\ntag = 1\nkind = \"dirichlet\"\n\
                        displacement = [0, 0]\n";
        assert_eq!(
            error_with(same_tag),
            "scene.toml: boundary[1] \"b\".tag: tag 1 is already used by boundary[0] \"a\""
        );
        // Names with control characters stay on one line.
        assert_eq!(
            error_with("[[boundary]]\nname = \"a\\nb\"\n"),
            "scene.toml: boundary[0] \"a\\nb\".kind: missing required key \
             (dirichlet, neumann or contact)"
        );
    }

    #[test]
    fn expression_errors_name_the_key() {
        let arc = "[[boundary]]\nname = \"top\"\ntag = 2\nkind = \"neumann\"\ntraction = [0, 0]\n\
                   [[boundary]]\nname = \"sides\"\ntag = 3\nkind = \"neumann\"\ntraction = [0, 0]\n\
                   [[boundary]]\nname = \"arc\"\nwhere = \"q > 0\"\nkind = \"contact\"\ngap = 0\n";
        assert_eq!(
            error_with(arc),
            "scene.toml: boundary[2] \"arc\".where: unknown variable 'q'"
        );
        assert_eq!(
            error_with(&boundary(
                "tag = 1\nkind = \"dirichlet\"\ndisplacement = [\"0\", \"-0.01*\"]"
            )),
            "scene.toml: boundary[0] \"b\".displacement[1]: \
             expected a value after '*' at end of expression"
        );
        assert_eq!(
            error_with(&boundary(
                "tag = 1\nkind = \"neumann\"\ntraction = [\"sin(t)\", 0]"
            )),
            "scene.toml: boundary[0] \"b\".traction[0]: unknown variable 't'"
        );
        assert_eq!(
            error_with(&boundary("tag = 1\nkind = \"contact\"\ngap = \"(x\"")),
            "scene.toml: boundary[0] \"b\".gap: unclosed '(' at column 1"
        );
        assert_eq!(
            error_with("[loads]\nbody_force = [\"0\", \"rho*g\"]\n"),
            "scene.toml: loads.body_force[1]: unknown variable 'rho'"
        );
        assert_eq!(
            error_with(&boundary(
                "where = \"\"\nkind = \"neumann\"\ntraction = [0, 0]"
            )),
            "scene.toml: boundary[0] \"b\".where: empty expression"
        );
    }

    #[test]
    fn stress_layout_key() {
        let scene = scene_with("[fields]\nstress_layout = \"XX, YY, XY\"\n");
        assert_eq!(
            scene.fields.stress_layout,
            StressLayout::for_component_count(3)
        );
        assert_eq!(
            error_with("[fields]\nstress_layout = \"xx,yy,zz\"\n"),
            "scene.toml: fields.stress_layout: component 'xy' (or 'yx') is missing"
        );
        assert_eq!(
            error_with("[fields]\nstress_layout = 4\n"),
            "scene.toml: fields.stress_layout: expected a string, found an integer (4)"
        );
    }

    #[test]
    fn component_lists_name_the_joined_array() {
        let scene = scene_with(
            "[fields]\ndisplacement = [\"disp_x\", \"disp_y\"]\n\
             stress = [\"sxx\", \"syy\", \"sxy\"]\n",
        );
        assert_eq!(
            scene.fields.displacement.as_deref(),
            Some("(disp_x, disp_y)")
        );
        assert_eq!(scene.fields.displacement_parts, ["disp_x", "disp_y"]);
        assert_eq!(scene.fields.stress.as_deref(), Some("(sxx, syy, sxy)"));
        assert_eq!(scene.fields.stress_parts, ["sxx", "syy", "sxy"]);
        let one = scene_with("[fields]\ndisplacement = \"u\"\n");
        assert_eq!(one.fields.displacement.as_deref(), Some("u"));
        assert!(one.fields.displacement_parts.is_empty());
    }

    #[test]
    fn load_scene_reads_files() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("scene.toml");
        std::fs::write(&file, format!("\u{feff}{EXAMPLE}")).unwrap();
        let scene = load_scene(&file).unwrap();
        assert_eq!(scene.file, file);
        assert_eq!(scene.boundaries.len(), 3);

        let missing = dir.path().join("absent.toml");
        let e = load_scene(&missing).unwrap_err();
        assert!(matches!(e, Error::Io { .. }), "{e:?}");
        assert!(
            e.to_string()
                .starts_with(&format!("{}: ", missing.display()))
        );

        let binary = dir.path().join("binary.toml");
        std::fs::write(&binary, b"[material]\n\xff\xfe").unwrap();
        assert_eq!(
            load_scene(&binary).unwrap_err().to_string(),
            format!(
                "{}: byte 11: not UTF-8 text (a scene file is TOML)",
                binary.display()
            )
        );
    }
}
