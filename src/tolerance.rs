//! Every tolerance and fixed numerical choice of fosls, with the reason for its value
//! (docs/design.md §4–§5). Nothing else in the library writes a bare tolerance literal.

/// Largest magnitude of any input value (field values, material constants, friction, ℓ,
/// obstacle data, expression values), and the inverse of the smallest Young's modulus: the
/// square or product of two such numbers (1e200) stays far from f64's overflow at 1.8e308,
/// which is what the terms of F compute (docs/robustness.md).
pub const MAX_MAGNITUDE: f64 = 1e100;

/// Planar meshes: z may vary by this times the largest |x|, |y| (writers that store z = 0
/// exactly, or a constant z plane, pass; a tilted mesh does not).
pub const PLANAR_RELATIVE: f64 = 1e-12;

/// A cell is degenerate when |det J| at its vertices is at most this times h_T² (h_T its
/// diameter): collinear vertices give round-off sized areas, valid slivers of aspect 1e4 have
/// 1e-4·h_T².
pub const DEGENERATE_AREA_RELATIVE: f64 = 1e-12;

/// A high-order node off its straight (affine or bilinear) position by more than this times
/// h_T makes the cell curved, and a quadrilateral whose vertices miss a parallelogram by more
/// makes it bilinear (docs/design.md §4.3). ASCII files with 12 significant digits perturb
/// straight cells by about 1e-12 absolute, i.e. ~1e-10 h_T on meshes with h ≥ 1e-2 and up to
/// ~1e-8 h_T at h = 1e-4; a mid node on a circle of radius R is off by h²/(8R), ≥ 1e-4 h_T for
/// every h ≥ 1e-3 R. 1e-6 separates the two by two orders of magnitude on either side.
pub const CURVED_RELATIVE: f64 = 1e-6;

/// A boundary vertex within this times |b − a| of a boundary edge a–b's curve, and this far
/// inside its parameter range, lies on it (`topology`'s hanging-node test). The same separation
/// as [`CURVED_RELATIVE`]: coordinates written with 7 to 12 significant digits put a vertex
/// that is on the edge at most ~1e-8 |b − a| off it on meshes with h ≥ 1e-4 × their size, while
/// a vertex that is not on it is a cell height away (the test also needs a chain of boundary
/// edges from a to b through such vertices, which a conforming mesh only has in a cell of zero
/// area).
pub const HANGING_NODE_RELATIVE: f64 = 1e-6;

/// A point array's value at a hanging node (a vertex or mid node of the neighbours inside an
/// edge of a split cell, `closure`) is taken to differ from the split cell's own trace there
/// when they differ by more than this fraction of the array's largest magnitude. Evaluating the
/// parent's polynomial at the node rounds at ~1e-15 of the values; a code that does not
/// constrain hanging values, or a low-order output of a quadratic field, differs by the field's
/// O(h²) variation, and float32 output by ~1e-7: those are kept as the cells' own copies.
pub const HANGING_JUMP_RELATIVE: f64 = 1e-12;

/// Longest chain of boundary edges followed along one edge in the hanging-node test: an edge
/// of a non-conforming mesh is split into 2^levels pieces (one or two levels in practice).
pub const HANGING_CHAIN: usize = 64;

/// Node copies of an exploded mesh closer than this times the shortest edge of the cells that
/// hold them are one node: writers copy coordinates bit-exactly or to ~1e-12 (ASCII), while
/// distinct nodes are at least an edge apart.
pub const MERGE_RELATIVE: f64 = 1e-6;

/// Relative tolerance (of the array's largest magnitude) under which two stress components are
/// taken as equal at a point, for the ambiguity test of 4-component arrays.
pub const EQUAL_COMPONENTS: f64 = 1e-12;

/// A nodal stress counts as symmetric when |σ_xy − σ_yx| ≤ this times max |σ| (round-off of an
/// L² projection or of a 9-component tensor written in single steps).
pub const SYMMETRY_RELATIVE: f64 = 1e-12;

/// Relative size below which σ_n (or 𝔉|σ_n| − |σ_t|) counts as zero when classifying the
/// contact state, relative to the largest |σ_n| on Γ_C: round-off must not make zones.
pub const STATE_RELATIVE: f64 = 1e-10;

/// A piece of Γ_C is in contact where the normal traction of the stress used is compressive
/// beyond this fraction of the largest |σ_n| on Γ_C (docs/design.md §5.8). The traction, not
/// the gap, decides: a penalty solution penetrates and an energy projection lifts it by up to
/// ~1e-5, which reopens gaps of that size, and P1 fields open gaps of h²/8R between active
/// nodes of a curved boundary. 1e-2 cuts the oscillating tails of a reconstructed σ_n beyond
/// the zone's ends (on the coarser quadrilateral Hertz meshes: 2a + 3.1 % at 1e-3, + 2.9 % at
/// 1e-2), while a Hertz pressure p₀(1 − x²/a²)^½ falls below 1e-2 p₀ only within 5e-5 a of
/// the ends; the triangle fixtures give 2a within 0.2 % for every threshold from 1e-4 to 1e-2.
pub const CONTACT_TRACTION_RELATIVE: f64 = 1e-2;

/// With a patch stress of a displacement far from a Galerkin solution
/// (`GALERKIN_DEFECT_RELATIVE`), a piece of Γ_C is in contact only where u_h is also closed within this fraction
/// of max |u_h| on Γ_C (`estimate::boundary::boundary_with`, docs/design.md §5.8): such a stress
/// carries the patches' load defects as pressure on nearly closed edges beyond the zone.
/// sfepy's vertex-only P2 Hertz file (penalty, penetration 6e-4 of the scale inside the zone):
/// 2a + 11.6 % with the traction alone, + 0.8 % at 1e-3, + 4.7 % at 1e-2. The Galerkin files do
/// not use it (at 1e-3 the P1 active-set files would lose up to 3 % of 2a: their gap opens
/// linearly across the edge where the zone ends, and the traction places the end better).
pub const ZONE_GAP_RELATIVE: f64 = 1e-3;

/// Reach of the local projection onto K_u (`reconstruct::projection`) in extents (box
/// diagonals) of the violating nodes. In 2D the energy of the best correction of a boundary
/// mismatch converges only slowly with the radius of the region it may use: on a 1M-cell P2
/// square with 41 penetrating nodes at one end of the contact side, the distance was 2.57 / 1.99
/// / 1.68 / 1.48 × the global projection's with reach 1 / 2 / 4 / 8, at 4.3 – 5.5 s and 2.1 GiB
/// for the whole stage against 67 s and 12.3 GiB globally. Any region gives an admissible v
/// with its exact distance (added to the bound): the reach trades bound for time.
pub const PROJECTION_REACH: f64 = 8.0;

/// Least reach of the local projection onto K_u (`reconstruct::projection`), in diameters of
/// the cells holding violating nodes: the region is the ball of radius max(extent of the
/// violations, this × h) around them, so that a single violating node still moves with a
/// few layers of cells around it.
pub const PROJECTION_LAYERS: f64 = 4.0;

/// Largest relative force defect of the closed patches (`PatchInfo::load_defect`) above which
/// the displacement is taken for far from any Galerkin solution, so that the contact zone of a
/// patch stress also needs the gap closed (`ZONE_GAP_RELATIVE`). Measured: Galerkin files
/// ≤ 1.6e-8 (solver tolerances); the manufactured files, whose body force the solver
/// integrated with another rule, 5e-5 – 8e-4; the perturbed files 2.4e-4; files interpolated
/// from a higher-order solution (sfepy's vertex-only P2 file, MFEM's refined low-order output)
/// 1.0. The traction alone places the zone's ends better where the defect is small (the
/// manufactured zones end inside edges, where the quadratic gap opens slowly).
pub const GALERKIN_DEFECT_RELATIVE: f64 = 1e-2;

/// Least scale of a closed patch's force defect in `PatchInfo::load_defect`, as a fraction of
/// the largest patch's load scale. A patch whose loads are themselves at the solver's residual
/// level has a relative defect of 1 whatever the solver did: the traction-free bottom corners
/// of the block-on-cylinder P1 file (scikit-fem active set) have loads of 3.9e-10 and 6.4e-10
/// and balances of the same size, and the file was taken for far from any Galerkin solution
/// (its zone then also needed the gap closed). 1e-6 lies above solver residuals (≤ 1.6e-8 of
/// the loads on the Galerkin files) and far below any load that carries the problem.
pub const LOAD_DEFECT_FLOOR: f64 = 1e-6;

/// Stick also needs |u_t| ≤ this times max |u_h| on Γ_C: a stress inside the cone with a
/// sliding displacement is slip. Regularised-friction solvers (NGSolve, ε = 1e-8) leave
/// |u_t| of 1e-5 max |u_h| in their stick zone; at 1e-4 the NGSolve and scikit-fem (exact
/// active set) P1 Coulomb Hertz files give the same stick length, 0.0687.
pub const STICK_SLIP_RELATIVE: f64 = 1e-4;

/// Relative size (of max |u_h| on Γ_C) below which an open gap counts as closed when
/// classifying the contact state: looser than [`STATE_RELATIVE`] because P2 displacements
/// constrained at the nodes only (active-set solvers, projections) leave gaps of that order
/// between the nodes of curved contact edges.
pub const GAP_RELATIVE: f64 = 1e-6;

/// Relative size below which a violation counts as round-off (of max |u_h| for displacement
/// checks, of max |σ_h| for stress checks) when deciding whether a hypothesis holds.
pub const ADMISSIBLE_RELATIVE: f64 = 1e-10;

/// Multiple of max |x| (the mesh's coordinates) added to the round-off level of displacement
/// checks: a gap (x − p)·n − u_n evaluated at |x| ~ X carries a few ε·X of absolute error,
/// whatever u_h is. The Hertz P1 file moved to (1e4, −3e4) and turned by 107° showed a
/// "penetration" of 1.9e-12 = 2.8 ε·X, above 1e-10 max |u_h| = 1e-12, and lost its guarantee;
/// 16 ε leaves a margin of 5 over that and is 3.6e-15 X, far below any penetration a solver
/// leaves on a mesh of size X.
pub const COORDINATE_ROUNDOFF: f64 = 16.0 * f64::EPSILON;

/// Coulomb coefficients below this are reconstructed with τ_t = 0 (the cone's axis, which is
/// admissible) instead of the cone variables w₁,₂ = ±τ_t + 𝔉τ_n: those map to τ_n with the
/// factor 1/(2𝔉), which multiplies the condition number by about 𝔉⁻², and at 𝔉 = 1e-8 breaks
/// the factorisation. The price is a friction term larger by at most 𝔉 ∫ |τ_n| |u_t|.
pub const MIN_CONE_FRICTION: f64 = 1e-6;

/// Quadrature degree of the interior terms on curved (and bilinear) cells, where the
/// integrands are rational: degree 10 resolves them to ~1e-12 relative for the curvatures of
/// boundary-fitted meshes (checked against degree 20 in the tests).
pub const CURVED_DEGREE: usize = 10;

/// Extra degree on bilinear quadrilaterals over the polynomial degree of the integrand on
/// parallelograms: 1/det J is smooth there, and four more orders keep the error of the rational
/// integrand below 1e-12 for aspect ratios up to ~10.
pub const BILINEAR_EXTRA_DEGREE: usize = 4;

/// Gauss–Legendre degree per piece of a boundary edge (20 points): exact for the degree-≤ 8
/// polynomial integrands of P2 data with a wide margin for curved edges and gap expressions
/// (boundary edges are few).
pub const EDGE_DEGREE: usize = 39;

/// Gauss–Legendre degree on contact edges for the loads of the displacement reconstruction:
/// the P2 × P2 × (curved) length-element integrands with a margin; |σ_n| is smooth for σ_n of
/// one sign.
pub const EDGE_DEGREE_NODAL: usize = 19;

/// Uniform samples per edge for bracketing zeros and maxima of boundary quantities.
pub const EDGE_SAMPLES: usize = 32;

/// A coefficient of a quadratic whose magnitude is below this times the scale of the other
/// coefficients counts as zero when solving for the roots in closed form.
pub const QUADRATIC_DEGENERATE: f64 = 1e-14;

/// Cap on active-set changes of the QP solver.
pub const MAX_ACTIVE_SET_ITERATIONS: usize = 200;

/// Floor of the complementarity constant c_i = K_ii of the active-set update λ_i + c_i x_i > 0
/// (relative to the largest |K_ii|): a zero diagonal entry would make the primal part of the
/// test vanish, and the update only needs c_i > 0 of the right scale.
pub const ACTIVE_SET_SCALE_FLOOR: f64 = 1e-12;

/// A reconstruction matrix K whose condition estimate (`solve::condition`, Jacobi-scaled, a
/// lower bound) reaches this is numerically singular and refused as "not positive definite"
/// (`solve`): the Cholesky factorisation of a singular K meets its zero pivot as round-off of
/// either sign, and a positive one (1e-15–5e-14 of K_jj) lets the factor through, so the
/// factorisation alone does not tell. Measured with the factor through: ν = 0.5 with only
/// Dirichlet and contact boundaries (the constant pressure free) gives 1.4e18 to 6.5e19 from
/// 268 to 246 656 unknowns; determined problems give at most 6.6e12 (ν = 0.4999999 at 554 304
/// unknowns, λ/μ = 1e7) and, for the badly scaled `seed` preset that the tool accepts with a
/// warning, 8.3e15 (P2 Hertz, 7976 unknowns; the path before the Schur complement gave 7.0e15
/// there). 1e17 (κu ≈ 11: the factorisation's round-off exceeds the smallest eigenvalue) lies
/// a factor ≥ 12 from either side. Pivot ratios do not separate the two (seed Hertz 1.5e-15).
/// These figures are of the whole K, before the interior RT DOFs were condensed; on the
/// condensed K the ν = 0.5 estimates can fall to 4.1e15–1.1e16 (design §5.5), which is why that
/// case is now refused from the structure first (`reconstruct::stress`) and this threshold is
/// the second line.
pub const SINGULAR_CONDITION: f64 = 1e17;

/// Diagonal regularisation (relative to the largest diagonal entry) of the split friction
/// unknowns a, b ≥ 0 of the displacement reconstruction, removed by a final solve.
pub const SPLIT_REGULARISATION: f64 = 1e-10;

/// Values below this times the field's scale count as zero in the friction remedy's sign test.
pub const SIGN_ROUNDOFF: f64 = 1e-12;

/// Pivot floor of the Jacobi scaling (relative to the largest diagonal entry).
pub const PIVOT_FLOOR: f64 = 1e-12;

/// Newton steps of the inverse cell map stop below this step in reference coordinates
/// (ξ ∈ [0, 1]²: about eight ulps), or after [`INVERSE_MAP_ITERATIONS`] steps; from the
/// reference correspondence of a sub-triangle the iteration converges quadratically, in
/// 3–5 steps on boundary-fitted meshes.
pub const INVERSE_MAP_STEP: f64 = 2e-15;

/// The diagonal node of a quadrilateral's triangle halves (`estimate::halves`) must be the
/// image of the inverse map's point to this fraction of the cell's diameter: converged Newton
/// steps reach round-off (1e-15), so a larger miss means the chord midpoint lies outside the
/// cell (a non-convex quadrilateral), where u_h is not defined. A cell taken for a
/// parallelogram is mapped affinely and may miss by up to [`CURVED_RELATIVE`] instead (a 100k
/// smoothly distorted Q2 mesh was refused at 1.5e-9).
pub const HALVES_DIAGONAL_MISS_RELATIVE: f64 = 1e-9;

/// A quadrilateral's triangle halves (`estimate::halves`) take the diagonal from vertex 1 to 3
/// instead of 0 to 2 when that makes their least angle this many times larger. Flipping only
/// distorted cells pays; flipping every cell whose other diagonal is better at all does not
/// (the scikit-fem Hertz files, bound: Q1 0.209 always 0–2, 0.241 flipped at any gain, 0.178
/// at 1.2, 0.175 at 1.5; Q2 0.0376 (K_T up to 40, not guaranteed), 0.0384, 0.0342, 0.0353;
/// S2 0.0649, 0.0651, 0.0591, 0.0618, all guaranteed from a gain of 1.2).
pub const HALVES_FLIP_GAIN: f64 = 1.2;

/// Cap on the Newton steps of the inverse cell map.
pub const INVERSE_MAP_ITERATIONS: usize = 30;

/// Poisson ratios at or above this are "near the incompressible limit" for messages: λ/μ =
/// 2ν/(1 − 2ν) ≥ 49, where the pressure mode of the reconstruction is nearly free and a failed
/// factorisation may be caused by it (the message mentions ν = 0.5 only then).
pub const NEAR_INCOMPRESSIBLE_NU: f64 = 0.49;

/// A displacement on a quadratic mesh is "given at the vertices only" when every mid-edge value
/// differs from the mean of its edge's end values by at most this times the field's largest
/// magnitude (round-off of a writer that interpolates linearly; a genuine P2 field on a curved
/// or loaded body misses the mean by the O(h²) curvature of the solution, far above 1e-10).
pub const VERTEX_ONLY_RELATIVE: f64 = 1e-10;

/// A cell stress and a displacement "do not belong together" when the cell stress differs
/// from the cell means of Cε(u_h) by more than this, relative in the area-weighted RMS
/// (docs/design.md §4.1). A solver's own pair agrees to its output precision (6 significant
/// digits in ASCII: 1e-6); 2 % is far above that and far below the 12 % of a P2 solution
/// written at its vertices only (sfepy's default output) or of a wrong material.
pub const CELL_STRESS_MISMATCH: f64 = 0.02;

/// Cap on active-set changes (bounds added or dropped) of one patch QP (`reconstruct::qp`): the
/// Goldfarb–Idnani dual method is finite (no working set recurs), and a patch has at most a few
/// dozen sign-constrained contact variables, each typically added once and rarely dropped; the
/// cap only guards against round-off breaking the monotonicity.
pub const PATCH_ACTIVE_SET_ITERATIONS: usize = 200;

/// Modified Gram–Schmidt of the patch rows (`reconstruct::qp`) re-orthogonalises a row only when
/// the first pass left less than this fraction of its norm ("twice is enough", Daniel, Gragg,
/// Kaufman & Stewart 1976: above 1/√2 one pass is already orthogonal to working precision).
pub const PATCH_REORTHOGONALISE: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// A violated bound whose Schur complement against the working set, in the metric of the
/// equality-reduced inverse K, is below this fraction of (M⁻¹)_pp counts as linearly dependent on
/// the working set and the equalities (`reconstruct::qp`): K is formed as M⁻¹ − M⁻¹Qᵀ S⁻¹ Q M⁻¹,
/// whose cancellation leaves errors ~1e-16 × cond(M) ≤ ~1e-12 relative on the patch matrices,
/// while a genuinely independent bound has a ratio well above 1e-6. Only with equality rows: in
/// the all-rows-penalised fallback (M + ρQᵀQ, no rows left) a bound pinned by the penalty has a
/// ratio ~M_pp/ρ, below this, yet no bound can depend on others there (`reconstruct::qp`).
pub const PATCH_QP_DEPENDENT_BOUND: f64 = 1e-9;

/// A bound slack x_i counts as violated above this fraction of max|x₀| (the equality-constrained
/// minimiser) in `reconstruct::qp`: the dense solve's round-off is ~1e-14 relative; what is
/// below is clipped to 0 at the end, so τ_n ≤ 0 still holds exactly.
pub const PATCH_QP_FEASIBILITY: f64 = 1e-12;

/// Weight of the equality rows, relative to max M_ii, when bounds and equalities are
/// incompatible and the patch QP is re-solved with the equalities as a penalty
/// (`reconstruct::qp`): large enough that the rows hold in the least-squares sense to ~1e-6 of
/// what the bounds allow, small enough that M + ρQᵀQ keeps ~8 digits in its Cholesky.
pub const PATCH_QP_PENALTY: f64 = 1e6;

/// Diagonal shift, relative to the largest diagonal entry, first tried when round-off makes a
/// patch matrix's Cholesky fail (`reconstruct::qp`; then ×100 up to three more times): the patch
/// matrices are positive definite in exact arithmetic, so only round-off is to be absorbed.
pub const PATCH_QP_REGULARISATION: f64 = 1e-12;

/// A patch's equality constraints count as met when every row's residual is below this
/// fraction of the row's scale Σ|B_kj x_j| + |d_k|: round-off of the dense solve is ~1e-13,
/// while a displacement that is not a Galerkin solution leaves defects of its solver tolerance.
pub const PATCH_DEFECT_RELATIVE: f64 = 1e-8;

/// A sweep's correction δ (`reconstruct::sweep`) is kept only when its rows (div δ = 0, the
/// weak symmetry) are met to this fraction of their scale, as for the patch rows: δ must not
/// move the equilibrium beyond round-off.
pub const SWEEP_DEFECT: f64 = 1e-8;

/// Weight of the asymmetry in the objective of the patch problems and of the sweeps,
/// ‖τ − Cε‖²_A + w/(2μ)‖as τ‖² (`reconstruct::patch`, `reconstruct::sweep`; with the weak
/// symmetry only). The bound pays for as σ_h through the symmetric correction of design
/// §5.11, which the plain A-norm does not see: with w = 0 one sweep raised the manufactured P2
/// index (n = 4: 1.95 → 2.19) while it lowered P1's (2.07 → 1.78). Measured with one sweep,
/// P1 / P2 at n = 4: w = 1 1.72 / 1.97, w = 4 1.70 / 1.89, w = 16 1.72 / 1.89, w = 64 1.76 /
/// 1.96. In the colour-ordered patch solves without a sweep (session 28), P1 / P2 at n = 4:
/// w = 0 1.91 / 1.98 (P2 n = 8: 1.57, above the 1.5 target), w = 4 1.85 / 1.90. Any w gives an
/// equilibrated stress and a valid bound; it only chooses among them.
pub const ASYMMETRY_WEIGHT: f64 = 4.0;

/// Singular values of the reference divergence matrix of the RT bubbles (condense.rs) below
/// this fraction of the largest are its kernel. The matrix is fixed per order: its zero singular
/// values (the curl of the cubic bubble for RT_2; the left kernel, the mean) are round-off
/// ~1e-16, its non-zero ones within 2 orders of magnitude of each other, so the cut cannot
/// misjudge the rank.
pub const CONDENSATION_RANK: f64 = 1e-10;

/// A dependent patch row whose right-hand side misses what the other rows give it by more than
/// this fraction of the largest right-hand side disagrees with them (`reconstruct::qp`): then
/// the rows are solved with the nearest right-hand side they can meet, instead of dropping the
/// later row. Dependent rows of a Galerkin solution agree to round-off (~1e-14 of the loads);
/// the disagreements that moved the Hertz Q2 halves' flows are 1e-6 to 1e-2 of them.
pub const INCONSISTENT_ROW: f64 = 1e-10;

/// A constraint row whose component orthogonal to the previous rows is below this fraction of
/// its norm is dependent (dropped; its consistency shows in the defect).
pub const PATCH_DEPENDENT_ROW: f64 = 1e-10;

/// The 2 × 2 block of a cell's P_1 weak-symmetry rows at its free interior values (RT_2,
/// `patch::eliminate_kernel`) counts as singular when |det| is below this fraction of its
/// largest entry squared. On a straight cell the block is −(∫_T b)·(the gradients of ξ − ⅓,
/// η − ⅓), regular with |det| ≈ its entries squared up to the cell's aspect ratio (1e-4 at
/// aspect 1e4): the cut only catches degenerate cells, which are then solved without those rows.
pub const KERNEL_PIVOT_RELATIVE: f64 = 1e-12;

/// The largest cond(J) of a straight cell whose free interior values are eliminated through its
/// P_1 symmetry rows (`patch::eliminate_kernel`): the 2 × 2 inverse multiplies the round-off by
/// cond(J). Up to 10 the patch results agree with the QP over all unknowns to round-off (bound
/// of the 100k P2 bench field within 2e-9 relative); at aspect 1e3 an exact pair's bound rose
/// from 3e-7 to 1.7e-5 of energy^½, so such cells keep their free values in the QP.
pub const KERNEL_ELIMINATION_CONDITION: f64 = 10.0;

/// A cell's rigid-motion moments of div τ + f, or the mean of as τ, count as zero below this
/// fraction of their scale (∫ h|div τ| + h|f|, ∫|τ_xy| + |τ_yx|): the patch reconstruction
/// meets them to ~1e-13, a non-equilibrated stress misses them by O(1).
pub const BOUND_MOMENT_RELATIVE: f64 = 1e-8;

/// Singular values of the Alfeld divergence matrix (`estimate::symmetric`) below this
/// fraction of the largest are its kernel: the matrix has exactly one zero singular value (the
/// mean) up to round-off ~1e-15, and its smallest non-zero one is above 1e-3 of the largest on
/// cells with angles down to 1° (tested), so the cut separates the two by orders of magnitude.
pub const SYMMETRIC_RANK: f64 = 1e-10;

/// After the symmetric correction, ‖as τ*‖_T counts as zero below this fraction of
/// max(‖as τ‖_T, stress scale × |T|^½): the exact elimination leaves ~1e-14.
pub const SYMMETRIC_RESIDUAL: f64 = 1e-9;

/// Conjugate-gradient cap and relative residual of the balancing flows between patches
/// (`reconstruct::flow`): the flows must cancel the patch defects to round-off, or the patch
/// problems stay infeasible; the graph Laplacian of a mesh of N vertices needs O(N^½) steps per
/// decade, so 10⁴ steps cover meshes far beyond 10⁶ vertices at 1e-14.
pub const FLOW_ITERATIONS: usize = 10_000;
pub const FLOW_RELATIVE: f64 = 1e-14;

/// Rounds of balancing flows and re-solved patches (`reconstruct::patch`): one round moves the
/// load defects; a patch whose active set then changes leaves a smaller residual for the next.
pub const FLOW_PASSES: usize = 3;

/// A further round of flows is made while some patch's defect is above this (up to
/// `FLOW_PASSES`): a defect below [`PATCH_DEFECT_RELATIVE`] counts as met for that patch, but
/// what it leaves in a cell's ∫ as σ_h is more than the symmetric correction can leave
/// ([`SYMMETRIC_RESIDUAL`]). The Hertz Q2 halves with the rotation moments about the mean of
/// the points stopped after one round at a defect of 2.3e-9, and 9 of 840 cells kept their
/// Korn term (bound not guaranteed); a second round gives 3e-14. Round-off of the patch solves
/// is ~1e-13.
pub const FLOW_PASS_DEFECT: f64 = 1e-11;

/// Quadrature degree for a body force that is not constant, in the patch loads
/// (`reconstruct::patch`) and in the bound's moment and oscillation terms (`estimate::bound`):
/// the SAME rule in both, so that the rigid-motion moments of div σ_h + f the bound checks are
/// the ones the patches balanced (a kinked f integrated by two rules differs by ~1e-3).
pub const LOAD_DEGREE: usize = 12;

/// Panels of the composite Gauss–Legendre rule (degree `LOAD_DEGREE` each) on a Dirichlet
/// edge for the energy of the data lifting (`estimate::data`): exact for polynomial data of
/// P2 fields; for data with a kink inside the edge (|||z||| depends on d′, which jumps there)
/// 4 panels put the kink's error at the size of the others. Boundary edges are few.
pub const DATA_PANELS: usize = 4;

/// Points per contact edge at which the P2 trace is checked between nodes and lifted
/// (`estimate::lift`): the admissibility check samples edges as finely.
pub const LIFT_SAMPLES: usize = 64;

/// Rounds of the lift's refinement (`estimate::lift`): each finds the largest penetration left
/// on the edge with the admissibility check's maximiser and raises the lift to close it there.
/// Two rounds closed the CalculiX two-body Hertz file's 5.3e-10 (a crossing between the
/// samples next to an active node); more only guard a maximiser that moves between rounds.
pub const LIFT_REFINE: usize = 8;

/// A bound term that uses an uncertified constant (the local Korn constant, Payne–Weinberger on
/// curved cells) does not cost the bound its guarantee while it is below this fraction of
/// |||v|||: it is then the round-off of the equilibration (patch rows are met to
/// `PATCH_DEFECT_RELATIVE`), and even a constant wrong by 100× would move the bound by less
/// than 1e-6 of |||v|||. The term is added to the bound either way.
pub const UNCERTIFIED_NEGLIGIBLE: f64 = 1e-8;

/// The bubble correction of the oscillation (`estimate::bubble`) is fitted on a cell only when
/// the oscillation's share W‖r‖² exceeds this fraction of the cell's Prager–Synge share: below
/// it the fit can gain at most ~1 % of the cell's share and costs ~0.2 ms per cell. The bound is
/// valid with or without it.
pub const BUBBLE_WORTH: f64 = 1e-2;

/// Samples (ends included) at which u_h must be open for a contact edge to be solved as
/// traction-free by the patch reconstruction (`reconstruct::patch`): the P2 trace is a quadratic,
/// so 9 samples see a touching interior point to within (1/8)² of the edge's curvature term.
pub const EDGE_OPEN_SAMPLES: usize = 9;

/// Relative size (of max |u_h| on Γ_C) above which a gap counts as open for the patch
/// reconstruction: a contact edge open by more than this at all its samples is solved
/// traction-free, and the P1 rotation shares put no pressure where an edge end is open by more.
/// A gap taken for open moves the patch's load defects to the Dirichlet sinks (flows), one taken
/// for closed allows a pressure that the complementarity pairing pays at the gap: freeing the
/// far arc of the P2 Hertz files (gaps up to 50 × max |u_h|) took their bound from 0.029 to
/// 0.018 (index 1.42), while a file lifted off its contact zone by a small perturbation
/// (perturbed_u_energy) must keep its pressure: freeing at 1e-6 or 1e-3 raised its bound from
/// 0.0105 to 0.250; at 1e-2 and 1e-1 it is unchanged. The NGSolve penalty P2 file: 0.93 at
/// 1e-6, 0.072 at 1e-4, 0.0191 from 1e-3 on.
pub const OPEN_GAP_RELATIVE: f64 = 1e-1;

/// A 6-node triangle whose mid nodes are off the edge midpoints by more than this fraction of
/// its diameter gets the symmetric correction of curved cells in the bound (the exact Piola
/// map), even when it counts as straight elsewhere: float32 coordinates put mid nodes ~1e-7 off,
/// and the reference-split correction then left an asymmetry of ~1e-9 of the stress scale on 30
/// CalculiX CPE6 cells. Double-precision midpoints are off by ~1e-16.
pub const STRAIGHT_MID_RELATIVE: f64 = 1e-12;

/// A rigid motion whose share of the contact edges' Gram matrix G (`problem::free_rigid_motions`)
/// is below this fraction of G's largest eigenvalue is left free by the scene: G is a sum of
/// squares of O(1) terms over a few edges, so round-off is ~1e-16 of its largest eigenvalue,
/// while a held motion has an eigenvalue of the order of (contact length / box size)³.
pub const FREE_MOTION_RELATIVE: f64 = 1e-12;
