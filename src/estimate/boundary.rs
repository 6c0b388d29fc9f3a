//! Boundary terms and boundary checks (docs/design.md §3, §5, §7).
//!
//! On a contact edge, with n_Ω the outward normal, (n, t) the contact frame, T = σ_h n_Ω:
//! σ_n = n·T, σ_t = t·T, u_n = n·u_h, u_t = t·u_h, g the gap along n, and
//!
//! - complementarity: ∫_E (u_n − g) σ_n ds (signed);
//! - friction (𝔉 > 0): ∫_E 𝔉|σ_n||u_t| + σ_t u_t ds (signed).
//!
//! Each edge is split at the zeros of σ_n, u_t, u_n − g and σ_t ± 𝔉σ_n, so that every |·| and
//! every positive part is smooth on each piece and Gauss–Legendre integrates the kinks exactly.
//! On straight edges these functions are polynomials of degree ≤ 2 in the edge parameter and
//! their zeros are computed in closed form; otherwise they are bracketed by sampling and
//! bisected to round-off. Each edge's contribution is attributed to its owning triangle.
//!
//! The same pass measures the violations of admissibility (§5) and the contact zone: the
//! state of each piece (in contact where the gap is closed, u_n − g ≥ 0, and the traction
//! compressive, σ_n < 0, both up to round-off; then stick where |σ_t| < 𝔉|σ_n|, slip
//! otherwise; separated elsewhere), merged into intervals along each contact boundary.
//! Requiring a closed gap keeps the small compressive oscillations of a projected nodal
//! stress away from the contact from counting as contact.

use super::{Admissibility, Contact, ContactInterval, ContactState, Violation};
use crate::expr::Expr;
use crate::field::{RtStress, StressField};
use crate::geometry::{Family, MAX_NODES, facet_point};
use crate::mesh::{Mesh, NONE};
use crate::problem::{BoundaryEdge, Condition, Context};
use crate::quadrature::line_rule_cached;
use crate::read::scene::{BoundaryKind, Contact as ContactSpec, ContactNormal, Scene};
use crate::tolerance::{
    ADMISSIBLE_RELATIVE, CONTACT_TRACTION_RELATIVE, COORDINATE_ROUNDOFF, EDGE_DEGREE, EDGE_SAMPLES,
    STATE_RELATIVE, STICK_SLIP_RELATIVE,
};

/// What the boundary pass needs (built from the [`Context`]).
struct Input<'a> {
    pub mesh: &'a Mesh,
    pub u: &'a [[f64; 2]],
    pub sigma: StressField<'a>,
    pub scene: &'a Scene,
    /// Every boundary edge with its condition.
    pub edges: &'a [BoundaryEdge],
}

/// Results of the boundary pass.
pub struct Boundary {
    /// Per triangle: the complementarity and friction terms of the edges it owns.
    pub complementarity: Vec<f64>,
    pub friction: Vec<f64>,
    pub admissibility: Admissibility,
    pub contact: Contact,
}

/// Fields of one cell, evaluated along one of its edges.
struct EdgeFields<'a> {
    mesh: &'a Mesh,
    cell: usize,
    rt: Option<&'a RtStress>,
    family: Family,
    x: [[f64; 2]; MAX_NODES],
    u: [[f64; 2]; MAX_NODES],
    s: [[f64; 4]; MAX_NODES],
    local: usize,
    /// Affine cell: the traces are polynomials of degree ≤ 2 in the edge parameter.
    straight: bool,
}

/// Values at one point of an edge.
#[derive(Clone, Copy, Debug)]
struct At {
    x: [f64; 2],
    /// |dx/ds|.
    ds: f64,
    /// Outward unit normal n_Ω.
    normal: [f64; 2],
    u: [f64; 2],
    /// Row-major stress.
    sigma: [f64; 4],
}

impl<'a> EdgeFields<'a> {
    fn new(inp: &Input<'a>, e: &BoundaryEdge) -> EdgeFields<'a> {
        let t = e.cell as usize;
        let nodes = inp.mesh.nodes(t);
        let mut f = EdgeFields {
            mesh: inp.mesh,
            cell: t,
            rt: match inp.sigma {
                StressField::Rt(rt) => Some(rt),
                StressField::Nodal(_) => None,
            },
            family: inp.mesh.family[t],
            x: inp.mesh.coords(t),
            u: [[0.0; 2]; MAX_NODES],
            s: [[0.0; 4]; MAX_NODES],
            local: e.local as usize,
            straight: inp.mesh.is_affine(t),
        };
        for (k, &p) in nodes.iter().enumerate() {
            f.u[k] = inp.u[p as usize];
            if let StressField::Nodal(sv) = inp.sigma {
                f.s[k] = sv[p as usize];
            }
        }
        f
    }

    /// Values at parameter s ∈ [0, 1] (from the edge's start vertex to its end vertex,
    /// counter-clockwise around the cell).
    fn at(&self, s: f64) -> At {
        let n = self.family.nodes();
        let fp = facet_point(self.family, &self.x[..n], self.local, s);
        let mut sigma = [0.0; 4];
        match self.rt {
            Some(rt) => sigma = rt.at_parent(self.mesh, self.cell, fp.xi).0,
            None => {
                for k in 0..n {
                    for (m, v) in sigma.iter_mut().enumerate() {
                        *v += self.s[k][m] * fp.phi[k];
                    }
                }
            }
        }
        At {
            x: fp.x,
            ds: fp.ds,
            normal: fp.normal,
            u: fp.value2(n, &self.u),
            sigma,
        }
    }
}

/// The traction σ n_Ω of a row-major stress.
#[inline]
fn traction(s: [f64; 4], n: [f64; 2]) -> [f64; 2] {
    [s[0] * n[0] + s[1] * n[1], s[2] * n[0] + s[3] * n[1]]
}

/// Contact quantities at a point (docs/design.md §2, §7).
#[derive(Clone, Copy, Debug)]
struct ContactAt {
    sn: f64,
    st: f64,
    un: f64,
    ut: f64,
    g: f64,
}

fn contact_at(a: &At, c: &ContactSpec) -> ContactAt {
    let n = c.direction(a.normal);
    let t = [-n[1], n[0]];
    let tr = traction(a.sigma, a.normal);
    ContactAt {
        sn: n[0] * tr[0] + n[1] * tr[1],
        st: t[0] * tr[0] + t[1] * tr[1],
        un: n[0] * a.u[0] + n[1] * a.u[1],
        ut: t[0] * a.u[0] + t[1] * a.u[1],
        g: c.gap_at(a.x, n),
    }
}

/// (u_n − g)σ_n; 0 where the gap is infinite (the contact direction never meets the
/// obstacle). There contact cannot happen, so the condition is σ_n = 0, as on a traction-free
/// edge: a σ_n ≠ 0 counts with the tension violations (`boundary`), not as an infinite pairing.
/// (The pairing used to be 0·∞ = 0 only for σ_n exactly 0: a reconstructed stress's round-off
/// σ_n ~ 1e-17 made F infinite and the run stop on a non-finite total.)
///
/// A gap within `roundoff.gap` of zero counts as closed, and a σ_n within `roundoff.stress` of
/// zero as none: a file whose contact points lie on the obstacle in exact arithmetic stores them
/// (and u_h) rounded, a reconstructed stress meets τ_n = 0 to its solve's round-off, and the
/// pairing of the two round-offs, though tiny, enters the estimate under a square root. An exact
/// solution turned by 107° gave η = 3.5e-8 of energy^½ from a gap of 2e-17 alone.
#[inline]
fn complementarity_density(c: &ContactAt, roundoff: Roundoff) -> f64 {
    if c.g.is_infinite() || (c.un - c.g).abs() <= roundoff.gap || c.sn.abs() <= roundoff.stress {
        0.0
    } else {
        (c.un - c.g) * c.sn
    }
}

/// 𝔉|σ_n||u_t| + σ_t u_t = |u_t| (𝔉|σ_n| + σ_t sgn u_t), 0 where the slip or the bracket is
/// round-off (as in [`complementarity_density`]): in a slip zone a reconstructed stress meets
/// σ_t = −𝔉|σ_n| sgn u_t to its solve's round-off, which the patch stress of an exact Coulomb
/// solution turned into η = 2.6e-7 of energy^½.
#[inline]
fn friction_density(c: &ContactAt, friction: f64, roundoff: Roundoff) -> f64 {
    let bracket = friction * c.sn.abs() + c.st * c.ut.signum();
    if c.ut.abs() <= roundoff.gap || bracket.abs() <= roundoff.stress {
        0.0
    } else {
        c.ut.abs() * bracket
    }
}

/// The round-off levels of the boundary pairings: of u_n − g and u_t (the coordinates' and
/// u_h's, `COORDINATE_ROUNDOFF`), and of a stress component (`ADMISSIBLE_RELATIVE` of its scale,
/// the level below which a stress violation is round-off).
#[derive(Clone, Copy)]
struct Roundoff {
    gap: f64,
    stress: f64,
}

/// The zeros in (0, 1) of `h`. With `quadratic`, `h` is a polynomial of degree ≤ 2 and its
/// zeros are computed from the values at 0, ½, 1; otherwise sign changes between uniform
/// samples are bisected to round-off.
fn zeros(h: impl Fn(f64) -> f64, quadratic: bool) -> Vec<f64> {
    let mut out = Vec::new();
    if quadratic {
        let (h0, h1, h2) = (h(0.0), h(0.5), h(1.0));
        if !(h0.is_finite() && h1.is_finite() && h2.is_finite()) {
            return out;
        }
        // h(s) = a s² + b s + c.
        let a = 2.0 * h2 - 4.0 * h1 + 2.0 * h0;
        let b = 4.0 * h1 - 3.0 * h0 - h2;
        let c = h0;
        let scale = h0.abs().max(h1.abs()).max(h2.abs());
        if scale == 0.0 {
            return out;
        }
        if a.abs() <= 1e-14 * scale {
            if b != 0.0 {
                out.push(-c / b);
            }
        } else {
            let disc = b * b - 4.0 * a * c;
            if disc > 0.0 {
                // The stable pair of roots.
                let q = -0.5 * (b + b.signum() * disc.sqrt());
                out.push(q / a);
                if q != 0.0 {
                    out.push(c / q);
                }
            }
        }
        out.retain(|&s| s > 0.0 && s < 1.0);
    } else {
        let v: Vec<f64> = (0..=EDGE_SAMPLES)
            .map(|i| h(i as f64 / EDGE_SAMPLES as f64))
            .collect();
        for i in 0..EDGE_SAMPLES {
            let (mut lo, mut hi) = (
                i as f64 / EDGE_SAMPLES as f64,
                (i + 1) as f64 / EDGE_SAMPLES as f64,
            );
            let (vl, vh) = (v[i], v[i + 1]);
            if !(vl.is_finite() && vh.is_finite()) {
                continue;
            }
            if vh == 0.0 && i + 1 < EDGE_SAMPLES {
                out.push(hi);
            } else if vl * vh < 0.0 {
                let up = vh > 0.0;
                for _ in 0..60 {
                    let mid = 0.5 * (lo + hi);
                    if (h(mid) > 0.0) == up {
                        hi = mid;
                    } else {
                        lo = mid;
                    }
                }
                out.push(0.5 * (lo + hi));
            }
        }
    }
    out
}

/// The largest value of `h` on [0, 1]: uniform samples, then a golden-section search around
/// the best one (the maxima of the smooth pieces are found to round-off).
pub(super) fn maximum(h: impl Fn(f64) -> f64) -> (f64, f64) {
    let mut best = (f64::NEG_INFINITY, 0.0);
    for i in 0..=EDGE_SAMPLES {
        let s = i as f64 / EDGE_SAMPLES as f64;
        let v = h(s);
        if v > best.0 {
            best = (v, s);
        }
    }
    let step = 1.0 / EDGE_SAMPLES as f64;
    let (mut a, mut b) = ((best.1 - step).max(0.0), (best.1 + step).min(1.0));
    let r = 0.5 * (5f64.sqrt() - 1.0);
    let (mut c, mut d) = (b - r * (b - a), a + r * (b - a));
    let (mut fc, mut fd) = (h(c), h(d));
    for _ in 0..60 {
        if fc > fd {
            b = d;
            d = c;
            fd = fc;
            c = b - r * (b - a);
            fc = h(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + r * (b - a);
            fd = h(d);
        }
    }
    for (v, s) in [(fc, c), (fd, d)] {
        if v > best.0 {
            best = (v, s);
        }
    }
    best
}

/// Accumulates one kind of violation: max with its place, and ∫ v² ds.
#[derive(Default)]
struct Acc {
    max: f64,
    at: Option<[f64; 2]>,
    cell: Option<usize>,
    l2sq: f64,
}

impl Acc {
    fn offer(&mut self, value: f64, at: [f64; 2], cell: usize) {
        if value > self.max {
            self.max = value;
            self.at = Some(at);
            self.cell = Some(cell);
        }
    }
    fn done(self) -> Violation {
        Violation {
            max: self.max,
            l2: self.l2sq.sqrt(),
            at: self.at,
            cell: self.cell,
        }
    }
}

/// A piece of a contact edge with one state.
struct Piece {
    state: ContactState,
    start: [f64; 2],
    end: [f64; 2],
    length: f64,
}

/// Merges intervals shorter than the local mesh size (the longest edge they touch) into their
/// neighbours (docs/design.md §5.8): into both when those agree, else into the longer one.
/// Such pieces are below the resolution of the discrete fields: sign flickers of σ_n or u_t
/// between the nodes of one edge, not zones.
fn merge_short(mut list: Vec<(ContactInterval, f64)>) -> Vec<(ContactInterval, f64)> {
    loop {
        let n = list.len();
        if n < 2 {
            return list;
        }
        let Some(i) = (0..n)
            .filter(|&i| list[i].0.length < list[i].1)
            .min_by(|&a, &b| list[a].0.length.total_cmp(&list[b].0.length))
        else {
            return list;
        };
        let into = match (i.checked_sub(1), (i + 1 < n).then_some(i + 1)) {
            (Some(l), Some(r)) if list[l].0.state == list[r].0.state => {
                let (short, right) = (list[i].clone(), list[r].clone());
                let left = &mut list[l];
                left.0.length += short.0.length + right.0.length;
                left.0.end = right.0.end;
                left.1 = left.1.max(short.1).max(right.1);
                list.drain(i..=r);
                continue;
            }
            (Some(l), Some(r)) => {
                if list[l].0.length >= list[r].0.length {
                    l
                } else {
                    r
                }
            }
            (Some(l), None) => l,
            (None, Some(r)) => r,
            (None, None) => return list,
        };
        let short = list.remove(i);
        let j = if into > i { into - 1 } else { into };
        let t = &mut list[j];
        t.0.length += short.0.length;
        t.1 = t.1.max(short.1);
        if into > i {
            t.0.start = short.0.start;
        } else {
            t.0.end = short.0.end;
        }
    }
}

/// Evaluates the boundary terms, the admissibility checks and the contact zone of `u` and
/// `sigma` in the problem `ctx`.
pub fn boundary(ctx: &Context, u: &[[f64; 2]], sigma: StressField) -> Boundary {
    boundary_with(ctx, u, sigma, None)
}

/// [`boundary`], with the contact zone also required to be closed: with
/// `zone_gap = Some(r)` a piece where u_h is open by more than r × max |u_h| on Γ_C is
/// separated whatever the traction, and pieces are cut where the gap crosses that level
/// (docs/design.md §5.8: for a patch stress of a displacement that is not a Galerkin
/// solution, which carries load defects on the nearly closed contact edges beyond the zone).
pub fn boundary_with(
    ctx: &Context,
    u: &[[f64; 2]],
    sigma: StressField,
    zone_gap: Option<f64>,
) -> Boundary {
    let inp = &Input {
        mesh: ctx.mesh,
        u,
        sigma,
        scene: ctx.scene,
        edges: ctx.edges,
    };
    let ncells = inp.mesh.cells.len();
    let mut out = Boundary {
        complementarity: vec![0.0; ncells],
        friction: vec![0.0; ncells],
        admissibility: Admissibility::default(),
        contact: Contact {
            line_state: vec![None; inp.mesh.lines.len()],
            ..Contact::default()
        },
    };
    let rule = line_rule_cached(EDGE_DEGREE);
    let sigma_scale = sigma.scale(ctx.mesh);
    let roundoff = Roundoff {
        gap: COORDINATE_ROUNDOFF
            * (crate::field::max_norm(&inp.mesh.points) + crate::field::max_norm(u)),
        stress: ADMISSIBLE_RELATIVE * sigma_scale,
    };
    let (mut pen, mut ten, mut cone) = (Acc::default(), Acc::default(), Acc::default());
    let (mut dir, mut neu) = (Acc::default(), Acc::default());

    // Scales of σ_n and u on Γ_C for the state tolerances.
    let mut sn_scale = 0.0f64;
    let mut u_scale = 0.0f64;
    for e in inp.edges {
        if let Condition::Contact(b) = e.condition {
            let c = contact_spec(inp.scene, b);
            let f = EdgeFields::new(inp, e);
            for i in 0..=4 {
                let a = f.at(i as f64 / 4.0);
                sn_scale = sn_scale.max(contact_at(&a, c).sn.abs());
                u_scale = u_scale.max(a.u[0].hypot(a.u[1]));
            }
        }
    }
    let tol = STATE_RELATIVE * sn_scale;
    let tol_contact = CONTACT_TRACTION_RELATIVE * sn_scale;
    let tol_slip = STICK_SLIP_RELATIVE * u_scale;
    let tol_open = zone_gap.map_or(f64::INFINITY, |r| r * u_scale);

    // Pieces of each contact boundary, per edge, for the intervals.
    let mut pieces: Vec<(usize, usize, Vec<Piece>)> = Vec::new(); // (boundary, edge index, pieces)

    for (ei, e) in inp.edges.iter().enumerate() {
        let t = e.cell as usize;
        let f = EdgeFields::new(inp, e);
        match e.condition {
            Condition::Contact(b) => {
                let c = contact_spec(inp.scene, b);
                let fr = c.friction;
                let poly_gap = matches!(c.gap, crate::read::scene::Gap::Plane { .. });
                let quadratic = f.straight && poly_gap;
                let q = |s: f64| contact_at(&f.at(s), c);
                let mut cuts = vec![0.0, 1.0];
                cuts.extend(zeros(|s| q(s).sn, f.straight));
                // The contact zone ends where σ_n crosses the threshold.
                cuts.extend(zeros(|s| q(s).sn + tol_contact, f.straight));
                cuts.extend(zeros(|s| q(s).ut, f.straight));
                if tol_open.is_finite() {
                    cuts.extend(zeros(
                        |s| {
                            let p = q(s);
                            p.g - p.un - tol_open
                        },
                        quadratic,
                    ));
                }
                cuts.extend(zeros(
                    |s| {
                        let p = q(s);
                        p.un - p.g
                    },
                    quadratic,
                ));
                if fr > 0.0 {
                    cuts.extend(zeros(|s| q(s).st - fr * q(s).sn, f.straight));
                    cuts.extend(zeros(|s| q(s).st + fr * q(s).sn, f.straight));
                } else {
                    cuts.extend(zeros(|s| q(s).st, f.straight));
                }
                cuts.sort_by(f64::total_cmp);
                cuts.dedup_by(|a, b| (*a - *b).abs() <= 1e-15);

                let mut edge_pieces = Vec::new();
                let (mut comp, mut fric) = (0.0, 0.0);
                for w in cuts.windows(2) {
                    let (a, bnd) = (w[0], w[1]);
                    let h = bnd - a;
                    if h <= 0.0 {
                        continue;
                    }
                    let mut length = 0.0;
                    for (&r, &wt) in rule.points.iter().zip(&rule.weights) {
                        let at = f.at(a + h * r);
                        let p = contact_at(&at, c);
                        let dw = wt * h * at.ds;
                        length += dw;
                        let dc = complementarity_density(&p, roundoff);
                        comp += dw * dc;
                        out.admissibility.complementarity_negative += dw * dc.min(0.0);
                        if fr > 0.0 {
                            let df = friction_density(&p, fr, roundoff);
                            fric += dw * df;
                            out.admissibility.friction_negative += dw * df.min(0.0);
                        }
                        out.contact.normal_force_stress -= dw * p.sn;
                        out.contact.tangential_force += dw * p.st;
                        pen.l2sq += dw * (p.un - p.g).max(0.0).powi(2);
                        // Where the gap is infinite σ_n must vanish (complementarity_density).
                        ten.l2sq += dw
                            * if p.g.is_infinite() {
                                p.sn * p.sn
                            } else {
                                p.sn.max(0.0).powi(2)
                            };
                        cone.l2sq += dw * (p.st.abs() - fr * p.sn.abs()).max(0.0).powi(2);
                    }
                    let mid = q(a + 0.5 * h);
                    // In contact where the traction is compressive beyond the threshold
                    // (docs/design.md §5.8), whatever the gap: P1 fields open gaps of h²/8R
                    // between active nodes on curved boundaries, penalty solutions close them
                    // by penetrating. Without friction that is "contact"; with friction stick
                    // needs the stress inside the cone and no slip.
                    let state = if mid.sn >= -tol_contact || mid.g - mid.un > tol_open {
                        ContactState::Separated
                    } else if fr <= 0.0 {
                        ContactState::Contact
                    } else if fr * mid.sn.abs() - mid.st.abs() > tol && mid.ut.abs() <= tol_slip {
                        ContactState::Stick
                    } else {
                        ContactState::Slip
                    };
                    edge_pieces.push(Piece {
                        state,
                        start: f.at(a).x,
                        end: f.at(bnd).x,
                        length,
                    });
                }
                out.complementarity[t] += comp;
                out.friction[t] += fric;

                for (acc, h) in [
                    (
                        &mut pen,
                        Box::new(|s: f64| {
                            let p = q(s);
                            p.un - p.g
                        }) as Box<dyn Fn(f64) -> f64>,
                    ),
                    (&mut ten, Box::new(|s: f64| q(s).sn)),
                    (
                        &mut cone,
                        Box::new(|s: f64| {
                            let p = q(s);
                            p.st.abs() - fr * p.sn.abs()
                        }),
                    ),
                ] {
                    let (v, s) = maximum(&h);
                    if v.is_finite() {
                        acc.offer(v, f.at(s).x, inp.mesh.file_cell[t] as usize);
                    }
                }
                // σ_n where the gap is infinite (complementarity_density): only the body's
                // normal can miss the plane (−m always meets it).
                if matches!(c.normal, ContactNormal::Body) {
                    let (v, s) = maximum(|s: f64| {
                        let p = q(s);
                        if p.g.is_infinite() { p.sn.abs() } else { 0.0 }
                    });
                    if v > 0.0 && v.is_finite() {
                        ten.offer(v, f.at(s).x, inp.mesh.file_cell[t] as usize);
                    }
                }

                if e.line != NONE {
                    let mut best = (ContactState::Separated, -1.0);
                    for st in [
                        ContactState::Separated,
                        ContactState::Contact,
                        ContactState::Stick,
                        ContactState::Slip,
                    ] {
                        let len: f64 = edge_pieces
                            .iter()
                            .filter(|p| p.state == st)
                            .map(|p| p.length)
                            .sum();
                        if len > best.1 {
                            best = (st, len);
                        }
                    }
                    out.contact.line_state[e.line as usize] = Some(best.0);
                }
                for p in &edge_pieces {
                    match p.state {
                        ContactState::Separated => {}
                        ContactState::Contact => out.contact.active_length += p.length,
                        ContactState::Stick => {
                            out.contact.active_length += p.length;
                            out.contact.stick_length += p.length;
                        }
                        ContactState::Slip => {
                            out.contact.active_length += p.length;
                            out.contact.slip_length += p.length;
                        }
                    }
                }
                pieces.push((b, ei, edge_pieces));
            }
            Condition::Dirichlet(b) => {
                let BoundaryKind::Dirichlet { displacement } = &inp.scene.boundaries[b].kind else {
                    continue;
                };
                let mismatch = |a: &At| {
                    let d = eval2(displacement, a.x);
                    (a.u[0] - d[0]).hypot(a.u[1] - d[1])
                };
                check(
                    &f,
                    &mut dir,
                    rule,
                    &mismatch,
                    inp.mesh.file_cell[t] as usize,
                );
            }
            Condition::Neumann(_) | Condition::Free => {
                let data = match e.condition {
                    Condition::Neumann(b) => match &inp.scene.boundaries[b].kind {
                        BoundaryKind::Neumann { traction } => Some(traction),
                        _ => None,
                    },
                    _ => None,
                };
                let mismatch = |a: &At| {
                    let tr = traction(a.sigma, a.normal);
                    let d = data.map_or([0.0; 2], |t| eval2(t, a.x));
                    (tr[0] - d[0]).hypot(tr[1] - d[1])
                };
                check(
                    &f,
                    &mut neu,
                    rule,
                    &mismatch,
                    inp.mesh.file_cell[t] as usize,
                );
            }
        }
    }
    out.admissibility.penetration = pen.done();
    out.admissibility.tension = ten.done();
    out.admissibility.cone_violation = cone.done();
    out.admissibility.dirichlet = dir.done();
    out.admissibility.neumann = neu.done();
    out.contact.normal_force = out.contact.normal_force_stress;
    out.contact.intervals = intervals(inp, &pieces);
    out.admissibility.u_scale = crate::field::max_norm(u);
    out.admissibility.sigma_scale = sigma_scale;
    out.admissibility.coordinate_scale = crate::field::max_norm(&ctx.mesh.points);
    // The zone's lengths from the merged intervals.
    let length_of = |st: ContactState| -> f64 {
        out.contact
            .intervals
            .iter()
            .filter(|c| c.state == st)
            .map(|c| c.length)
            .sum()
    };
    out.contact.stick_length = length_of(ContactState::Stick);
    out.contact.slip_length = length_of(ContactState::Slip);
    out.contact.active_length =
        out.contact.stick_length + out.contact.slip_length + length_of(ContactState::Contact);
    out
}

/// Max (sampled and refined) and L² (Gauss) of a smooth mismatch on one edge.
fn check(
    f: &EdgeFields,
    acc: &mut Acc,
    rule: &crate::quadrature::LineRule,
    mismatch: &dyn Fn(&At) -> f64,
    cell: usize,
) {
    for (&r, &w) in rule.points.iter().zip(&rule.weights) {
        let a = f.at(r);
        acc.l2sq += w * a.ds * mismatch(&a).powi(2);
    }
    let (v, s) = maximum(|s| mismatch(&f.at(s)));
    acc.offer(v, f.at(s).x, cell);
}

fn eval2(e: &[Expr; 2], x: [f64; 2]) -> [f64; 2] {
    [e[0].eval(x[0], x[1], 0.0), e[1].eval(x[0], x[1], 0.0)]
}

fn contact_spec(scene: &Scene, b: usize) -> &ContactSpec {
    match &scene.boundaries[b].kind {
        BoundaryKind::Contact(c) => c,
        // Conditions are built from the scene: a Contact condition names a contact boundary.
        _ => unreachable!("boundary {b} is not a contact boundary"),
    }
}

/// Merges the pieces of each contact boundary into maximal intervals of one state, following
/// the boundary counter-clockwise (edge after edge, end vertex to start vertex).
fn intervals(inp: &Input, pieces: &[(usize, usize, Vec<Piece>)]) -> Vec<ContactInterval> {
    let mut out = Vec::new();
    let mut boundaries: Vec<usize> = pieces.iter().map(|p| p.0).collect();
    boundaries.sort_unstable();
    boundaries.dedup();
    for b in boundaries {
        let mine: Vec<&(usize, usize, Vec<Piece>)> = pieces.iter().filter(|p| p.0 == b).collect();
        let ends = |p: &(usize, usize, Vec<Piece>)| {
            let e = &inp.edges[p.1];
            let [a, b, _] = inp.mesh.edge(e.cell as usize, e.local as usize);
            (a, b)
        };
        let starts: std::collections::HashMap<u32, usize> = mine
            .iter()
            .enumerate()
            .map(|(i, p)| (ends(p).0, i))
            .collect();
        let ending: std::collections::HashSet<u32> = mine.iter().map(|p| ends(p).1).collect();
        let mut used = vec![false; mine.len()];
        let mut order = Vec::with_capacity(mine.len());
        // Chains start where no edge of the boundary ends; closed loops anywhere.
        let firsts: Vec<usize> = (0..mine.len())
            .filter(|&i| !ending.contains(&ends(mine[i]).0))
            .chain(0..mine.len())
            .collect();
        for first in firsts {
            let mut i = first;
            let mut chain = Vec::new();
            while !used[i] {
                used[i] = true;
                chain.push(i);
                match starts.get(&ends(mine[i]).1) {
                    Some(&next) => i = next,
                    None => break,
                }
            }
            if !chain.is_empty() {
                order.push(chain);
            }
        }
        let name = inp.scene.boundaries[b].name.clone();
        for chain in order {
            let mut current: Option<(ContactInterval, f64)> = None;
            // (interval, the largest edge length it touches).
            let mut list: Vec<(ContactInterval, f64)> = Vec::new();
            for &i in &chain {
                let edge_length: f64 = mine[i].2.iter().map(|p| p.length).sum();
                for p in &mine[i].2 {
                    match current.as_mut() {
                        Some((c, h)) if c.state == p.state => {
                            c.end = p.end;
                            c.length += p.length;
                            *h = h.max(edge_length);
                        }
                        _ => {
                            if let Some(c) = current.take() {
                                list.push(c);
                            }
                            current = Some((
                                ContactInterval {
                                    boundary: name.clone(),
                                    state: p.state,
                                    start: p.start,
                                    end: p.end,
                                    length: p.length,
                                },
                                edge_length,
                            ));
                        }
                    }
                }
            }
            if let Some(c) = current {
                list.push(c);
            }
            out.extend(merge_short(list).into_iter().map(|c| c.0));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quadratic_zeros_in_closed_form() {
        // (s − 0.25)(s − 0.6) and a linear function.
        let z = zeros(|s| (s - 0.25) * (s - 0.6), true);
        let mut z = z;
        z.sort_by(f64::total_cmp);
        assert!(
            (z[0] - 0.25).abs() < 1e-15 && (z[1] - 0.6).abs() < 1e-15,
            "{z:?}"
        );
        assert_eq!(zeros(|s| 2.0 * s - 1.0, true), vec![0.5]);
        assert!(zeros(|s| s * s + 1.0, true).is_empty());
        assert!(zeros(|_| 0.0, true).is_empty());
    }

    #[test]
    fn sampled_zeros_are_bisected_to_round_off() {
        let z = zeros(|s: f64| (3.0 * s).sin() - 0.5, false);
        // sin(3s) = 1/2 at s = π/18 (and 5π/18 ≈ 0.873).
        assert_eq!(z.len(), 2);
        assert!((z[0] - std::f64::consts::PI / 18.0).abs() < 1e-15);
        assert!((z[1] - 5.0 * std::f64::consts::PI / 18.0).abs() < 1e-15);
    }

    #[test]
    fn maximum_of_a_parabola_inside_a_sample_interval() {
        let (v, s) = maximum(|s| 1.0 - (s - 0.31416).powi(2));
        assert!((v - 1.0).abs() < 1e-15);
        assert!((s - 0.31416).abs() < 1e-7);
    }
}
