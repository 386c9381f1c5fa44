//! A move's adaptive grid of `σ` (module docs, step 2): the [`Move`] with `A`, `A'` and the
//! steer angles tabulated at its nodes, built by [`Ctx::build_move`] (a node at every kink,
//! equal cells between, refined to [`GRID_TOL`] or [`GRID_TOL_TIME_OPTIMAL`]) and the one-sided
//! derivatives at kinks. The cell lookup is [`super::cells`].

use crate::PlanningError;
use crate::limits::MAX_MOVE_GRID_CELLS;
use crate::robot::MAX_CHANNELS;
use omnikin::MAX_WHEELS;

use super::geometry::{Config, Ctx, Hint, Kind, Steer};
use super::move_timing::MoveTiming;
use super::options::Timing;

/// Finest grid step in the move parameter (m or rad).
pub(super) const GRID_MIN: f64 = 2e-3;

/// Coarsest grid step in the move parameter (m or rad) for the profile and constant-speed
/// timings.
pub(super) const GRID_MAX: f64 = 0.05;

/// [`GRID_MAX`] for the time-optimal timing. Its pass is exact at the nodes, and the final
/// check on the samples mends any excess between them where it occurs (by refining the grid
/// there, [`Ctx::refine`]), so a coarse start costs little time-optimality: over the presets
/// on two splines at 0.5–3 m/s the plans came out between 2.9 % shorter and 0.4 % longer than
/// with 5 cm cells and a whole-move slow-down (the grid on the peer bench's spline 246 → 122
/// nodes; 20 cm cells: up to 1.4 % longer). Since the stretches where the profile switches are
/// refined ([`super::switches::SWITCH_FACTOR`]) the start is 15 cm: against
/// `tests/reference.rs` (40 cases) 15 cm with 4× at the switches gave median +0.036 %, worst
/// +0.611 %, against 10 cm with 3× median +0.044 %, worst +0.530 %, for 13 % fewer
/// instructions on the 20-waypoint benchmark plan (985 k → 858 k; 18.685 s against 18.684 s);
/// 15 cm with 3× had a worst of +1.132 %, 20 cm with 5× +7.0 %.
pub(super) const GRID_MAX_TIME_OPTIMAL: f64 = 0.15;

/// Largest linear-interpolation error of the motor rates per unit speed `A(σ)` between grid
/// nodes, relative to the motor's largest `|A|` on the move, for the profile and
/// constant-speed timings: their time dilation is computed from the peaks seen at the nodes,
/// so a coarser grid would under-estimate them and leave the final check more slow-down
/// rounds (each a full sampling).
const GRID_TOL: f64 = 1e-2;

/// [`GRID_TOL`] for the time-optimal timing, which needs less: its speed caps include the
/// bulge of `A` between nodes, its acceleration constraints are exact at the nodes, and the
/// final check refines the grid where a residual excess shows (see [`GRID_MAX_TIME_OPTIMAL`]).
const GRID_TOL_TIME_OPTIMAL: f64 = 2e-1;

/// The grid tolerance a timing needs ([`GRID_TOL`], [`GRID_TOL_TIME_OPTIMAL`]).
pub(super) fn grid_tol(timing: &Timing) -> f64 {
    match timing {
        Timing::TimeOptimal { .. } => GRID_TOL_TIME_OPTIMAL,
        Timing::Profile { .. } | Timing::ConstantSpeed { .. } => GRID_TOL,
    }
}

/// The coarsest grid step a timing needs ([`GRID_MAX`], [`GRID_MAX_TIME_OPTIMAL`]).
pub(super) fn grid_max(timing: &Timing) -> f64 {
    match timing {
        Timing::TimeOptimal { .. } => GRID_MAX_TIME_OPTIMAL,
        Timing::Profile { .. } | Timing::ConstantSpeed { .. } => GRID_MAX,
    }
}

/// Fewest grid cells per move.
pub(super) const MIN_CELLS: usize = 16;

/// A move with its grid: node parameters, heading (unwrapped), `A`, `A'` (one column per
/// motor channel) and the steer angles of steerable kinds.
#[derive(Clone, Debug)]
pub(super) struct Move {
    pub(super) kind: Kind,
    pub(super) len: f64,
    /// The stretches between kinks: their ends (`σ`, from 0 to `len`) and cell counts.
    pub(super) bounds: Vec<f64>,
    pub(super) cells: Vec<usize>,
    pub(super) sig: Vec<f64>,
    pub(super) psi: Vec<f64>,
    /// `(cos ψ, sin ψ)` at each node (the heading hint of the samples in its cell).
    pub(super) cs: Vec<[f64; 2]>,
    /// The path piece of each node (travel moves; the piece hint of the samples in its cell).
    pub(super) piece: Vec<Option<usize>>,
    pub(super) a: Vec<[f64; MAX_CHANNELS]>,
    /// `A'` at each node as seen from the cell that ends there (one-sided at a kink).
    pub(super) b_in: Vec<[f64; MAX_CHANNELS]>,
    /// `A'` at each node as seen from the cell that starts there (one-sided at a kink).
    pub(super) b_out: Vec<[f64; MAX_CHANNELS]>,
    pub(super) gamma: Vec<Steer>,
    pub(super) timing: MoveTiming,
    pub(super) t0: f64,
    /// Factor (≤ 1) per grid cell on the motor limits the time-optimal pass aims at, lowered
    /// around a residual excess the final check on the samples finds (empty: 1 everywhere).
    pub(super) limit_scale: Vec<f64>,
    /// `x = σ̇²` the move starts with (m²/s²): 0 from rest, the square of the start speed for
    /// a plan's first move when it starts moving ([`super::plan_from_velocity`]).
    pub(super) x_start: f64,
}

impl Ctx<'_> {
    /// Builds a move's grid starting from heading `psi_start` and steer angles `gamma0`. The
    /// grid has a node at every kink `kinks` (σ where `A'` may jump: the joins of the path's
    /// pieces; strictly increasing) and, between kinks, equal cells of at most `step`, refined (once, by the factor
    /// the error estimate asks for) until the linear interpolation of every motor's `A(σ)`
    /// between nodes is within [`Ctx::grid_tol`] of that motor's largest `|A|` on the move, or
    /// the cells are [`GRID_MIN`].
    pub(super) fn build_move(
        &self,
        kind: Kind,
        len: f64,
        psi_start: f64,
        gamma0: Steer,
        step: f64,
        kinks: &[f64],
    ) -> Result<Move, PlanningError> {
        debug_assert!(
            kinks.windows(2).all(|w| w[0] < w[1]),
            "kinks must increase strictly: {kinks:?}"
        );
        // Stretches between kinks, each with its number of cells.
        let mut bounds = vec![0.0];
        bounds.extend(
            kinks
                .iter()
                .copied()
                .filter(|&k| k > 1e-9 && k < len - 1e-9),
        );
        bounds.push(len);
        let cells = |l: f64, h: f64| ((l / h).ceil() as usize).max(1);
        let mut n: Vec<usize> = bounds
            .windows(2)
            .map(|w| cells(w[1] - w[0], step))
            .collect();
        let total: usize = n.iter().sum();
        if total < MIN_CELLS {
            let f = MIN_CELLS.div_ceil(total);
            n.iter_mut().for_each(|c| *c *= f);
        }
        too_many_cells(len, &n)?;
        self.grid_on(kind, len, psi_start, gamma0, bounds, n, None)
    }

    /// A move's grid again with `factor` times the cells (at most [`GRID_MIN`] apart) in the
    /// stretches `stretches` (indices into `mv.bounds`): four for a residual excess the final
    /// check found there (a doubling took about twice the rounds, each a full sampling, for
    /// the same plans), [`super::switches::SWITCH_FACTOR`] where the profile switches; `None`
    /// when none of them can be refined further.
    pub(super) fn refine(
        &self,
        mv: &Move,
        stretches: &[usize],
        factor: usize,
    ) -> Result<Option<Move>, PlanningError> {
        let mut n = mv.cells.clone();
        let mut changed = false;
        for &j in stretches {
            let l = mv.bounds[j + 1] - mv.bounds[j];
            let finest = ((l / GRID_MIN).ceil() as usize).max(1);
            let want = (factor * n[j]).min(finest);
            if want > n[j] {
                n[j] = want;
                changed = true;
            }
        }
        if !changed {
            return Ok(None);
        }
        too_many_cells(mv.len, &n)?;
        let mut out = self.grid_on(
            mv.kind.clone(),
            mv.len,
            mv.psi[0],
            mv.gamma[0],
            mv.bounds.clone(),
            n,
            Some(mv),
        )?;
        out.t0 = mv.t0;
        out.x_start = mv.x_start;
        Ok(Some(out))
    }

    /// The grid of a move on the stretches between `bounds` with `n` equal cells each, refined
    /// where the interpolation error asks for it (see [`Ctx::build_move`]). With `old` (the same
    /// move on the same `bounds`), a stretch whose cell count is unchanged takes its nodes from
    /// `old` instead of the kinematics, unless it is steered and follows a changed stretch (its
    /// steer angles carry over from there).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn grid_on(
        &self,
        kind: Kind,
        len: f64,
        psi_start: f64,
        gamma0: Steer,
        bounds: Vec<f64>,
        mut n: Vec<usize>,
        old: Option<&Move>,
    ) -> Result<Move, PlanningError> {
        let cells = |l: f64, h: f64| ((l / h).ceil() as usize).max(1);
        // Each stretch starts from the end state (heading, steer angles) of the one before.
        let steered = self.robot.steerable();
        let mut parts: Vec<Stretch> = Vec::with_capacity(n.len());
        // Every stretch's nodes in one vector (a rebuilt stretch appends its new nodes).
        let mut arena: Vec<Node> = Vec::with_capacity(n.iter().sum::<usize>() + n.len());
        // Stretch j with `cells` cells, appended to the arena, from the end of stretch j − 1.
        let build = |arena: &mut Vec<Node>,
                     parts: &[Stretch],
                     j: usize,
                     cells: usize,
                     coarse: Option<Coarse>| {
            let start = start_of(parts, arena, j, psi_start, gamma0);
            self.stretch(
                arena,
                &kind,
                len,
                bounds[j],
                bounds[j + 1],
                cells,
                start,
                coarse,
            )
        };
        // Where stretch j's nodes start in `old`, and whether a stretch before it changed.
        let mut old_first = 0;
        let mut changed = false;
        for j in 0..n.len() {
            let keep = old.filter(|o| {
                o.cells.len() == n.len() && o.cells[j] == n[j] && !(steered && changed)
            });
            let part = match keep {
                Some(o) => {
                    let first = arena.len();
                    // The first node is the previous stretch's last (the same parameter).
                    let skip = if j > 0 {
                        arena.push(*parts[j - 1].last(&arena));
                        1
                    } else {
                        0
                    };
                    arena.extend((old_first + skip..=old_first + n[j]).map(|i| Node {
                        psi: o.psi[i],
                        cs: o.cs[i],
                        a: o.a[i],
                        gamma: o.gamma[i],
                        piece: o.piece[i],
                    }));
                    Stretch {
                        s0: bounds[j],
                        s1: bounds[j + 1],
                        cells: n[j],
                        first,
                    }
                }
                None => {
                    changed = true;
                    // A stretch refined by a whole factor keeps the old nodes, which fall on
                    // every `factor`-th new one (the same parameters, bit for bit: `i / n`
                    // and `f i / f n` round alike), for a robot without steering (a
                    // steering's state would carry the coarser integration over).
                    let coarse = old
                        .filter(|o| !steered && o.cells.len() == n.len() && o.cells[j] > 0)
                        .filter(|o| n[j].is_multiple_of(o.cells[j]))
                        .map(|o| Coarse {
                            mv: o,
                            first: old_first,
                            factor: n[j] / o.cells[j],
                        });
                    build(&mut arena, &parts, j, n[j], coarse)?
                }
            };
            if let Some(o) = old {
                old_first += o.cells.get(j).copied().unwrap_or(0);
            }
            parts.push(part);
        }
        // Refine the stretches whose interpolation error is too large, rebuilding only them (and,
        // for steerable kinds, whose steer angles carry over, every stretch after the first rebuilt).
        let chans = self.robot.channels();
        // Each stretch's largest |A| and |A'|, recomputed only when it is rebuilt.
        let mut scales: Vec<[[f64; MAX_CHANNELS]; 2]> =
            parts.iter().map(|p| p.scale(&arena, chans)).collect();
        for _ in 0..8 {
            let mut scale = [[0.0_f64; MAX_CHANNELS]; 2];
            for ps in &scales {
                for i in 0..2 {
                    for ch in 0..chans {
                        scale[i][ch] = scale[i][ch].max(ps[i][ch]);
                    }
                }
            }
            let mut dirty = false;
            for j in 0..parts.len() {
                let c = n[j];
                let h = (bounds[j + 1] - bounds[j]) / c as f64;
                let err = parts[j].error(&arena, &scale, chans);
                let refine = err > self.grid_tol && h > GRID_MIN;
                if refine {
                    // Linear interpolation error scales with h²; aim at half the tolerance.
                    let f = (err / (0.5 * self.grid_tol)).sqrt().min(1e3);
                    let want = ((c as f64 * f).ceil() as usize).max(c + 1);
                    n[j] = want.min(cells(bounds[j + 1] - bounds[j], GRID_MIN).max(c));
                }
                if refine || (steered && dirty) {
                    parts[j] = build(&mut arena, &parts, j, n[j], None)?;
                    scales[j] = parts[j].scale(&arena, chans);
                    dirty = true;
                }
            }
            if !dirty {
                break;
            }
            too_many_cells(len, &n)?;
        }
        let total: usize = n.iter().sum();
        let mut sig = Vec::with_capacity(total + 1);
        let mut psi = Vec::with_capacity(total + 1);
        let mut cs = Vec::with_capacity(total + 1);
        let mut a = Vec::with_capacity(total + 1);
        let mut gamma = Vec::with_capacity(total + 1);
        let mut piece = Vec::with_capacity(total + 1);
        for (j, p) in parts.iter().enumerate() {
            let skip = usize::from(j > 0);
            for (i, node) in p.nodes(&arena).iter().enumerate().skip(skip) {
                sig.push(p.sigma(i));
                psi.push(node.psi);
                cs.push(node.cs);
                a.push(node.a);
                gamma.push(node.gamma);
                piece.push(node.piece);
            }
        }
        let (b_in, b_out) = derivative(&a, &sig, &n, chans);
        Ok(Move {
            kind,
            len,
            bounds,
            cells: n,
            sig,
            psi,
            cs,
            piece,
            a,
            b_in,
            b_out,
            gamma,
            timing: MoveTiming::Constant { v: 1.0 },
            t0: 0.0,
            limit_scale: Vec::new(),
            x_start: 0.0,
        })
    }

    /// One stretch of a move's grid: `n` equal cells from `s0` to `s1`, starting from heading
    /// hint and steer angles of `start`, or from the previous stretch's last node; with
    /// `coarse`, the nodes that coincide with the same stretch's nodes on a coarser grid are
    /// copied from it instead of evaluated.
    #[allow(clippy::too_many_arguments)]
    fn stretch(
        &self,
        arena: &mut Vec<Node>,
        kind: &Kind,
        len: f64,
        s0: f64,
        s1: f64,
        n: usize,
        start: Start,
        coarse: Option<Coarse>,
    ) -> Result<Stretch, PlanningError> {
        let out = Stretch {
            s0,
            s1,
            cells: n,
            first: arena.len(),
        };
        // Heading (and its cosine and sine), `A` and steer angles at each node; the first is
        // the previous stretch's last (the same parameter) when there is one.
        let (mut hint, mut g, first) = match start {
            Start::Fresh(hint, g) => (hint, g, 0),
            Start::After(node) => {
                arena.push(node);
                (node.hint(), node.gamma, 1)
            }
        };
        let steered = self.robot.steerable();
        let mut prev = s0;
        for k in first..=n {
            if let Some(c) = coarse.as_ref().filter(|c| k % c.factor == 0) {
                let node = c.node(k / c.factor);
                hint = node.hint();
                arena.push(node);
                continue;
            }
            let sigma = out.sigma(k);
            if k > 0 && steered {
                g = self.steer_step(kind, len, prev, g, sigma - prev, hint)?;
            }
            let c = self.config(kind, len, sigma, hint);
            hint = Hint::of(&c);
            arena.push(Node {
                psi: c.pose.heading,
                cs: c.cs,
                a: self.rates_per_speed(kind, len, sigma, &c, &g)?,
                gamma: g,
                piece: c.piece,
            });
            prev = sigma;
        }
        Ok(out)
    }

    /// Node `k` of `mv` as the heading (and path piece) hint of the points in its cell.
    pub(super) fn hint_at(&self, mv: &Move, k: usize) -> Hint {
        Hint {
            psi: mv.psi[k],
            cs: Some(mv.cs[k]),
            piece: mv.piece[k],
        }
    }

    /// Steer angles at `sigma` within a move (integrated ones; for set-points those of the
    /// cell's start node), and the configuration there; `k` is the grid cell holding `sigma`
    /// (its start node is the heading hint and the steer integration's start).
    pub(super) fn state(
        &self,
        mv: &Move,
        sigma: f64,
        k: usize,
    ) -> Result<(Config, Steer), PlanningError> {
        let hint = self.hint_at(mv, k);
        let c = self.config(&mv.kind, mv.len, sigma, hint);
        if self.set_point || !self.robot.steerable() {
            // Set-points come from the inverse at each sample (see `sample`); kinds without
            // steering keep their (zero) angles.
            return Ok((c, mv.gamma[k]));
        }
        let g = self.steer_step(
            &mv.kind,
            mv.len,
            mv.sig[k],
            mv.gamma[k],
            (sigma - mv.sig[k]).max(0.0),
            hint,
        )?;
        Ok((c, g))
    }
}

/// Where stretch `j` starts: from the move's start heading and steer angles, or from the last
/// node of stretch `j − 1`.
fn start_of(parts: &[Stretch], arena: &[Node], j: usize, psi_start: f64, gamma0: Steer) -> Start {
    if j == 0 {
        Start::Fresh(Hint::angle(psi_start), gamma0)
    } else {
        Start::After(*parts[j - 1].last(arena))
    }
}

/// The same stretch on a coarser grid of the same move, whose node `i` is node `factor · i`
/// of the finer one ([`Ctx::stretch`]).
struct Coarse<'a> {
    mv: &'a Move,
    /// Index of the stretch's first node in `mv`'s node vectors.
    first: usize,
    factor: usize,
}

impl Coarse<'_> {
    /// The stretch's node `i` on the coarser grid.
    fn node(&self, i: usize) -> Node {
        let (o, i) = (self.mv, self.first + i);
        Node {
            psi: o.psi[i],
            cs: o.cs[i],
            a: o.a[i],
            gamma: o.gamma[i],
            piece: o.piece[i],
        }
    }
}

/// Where a stretch starts: a heading hint and steer angles, or the previous stretch's last
/// node (the same parameter).
enum Start {
    Fresh(Hint, Steer),
    After(Node),
}

/// One grid node of a stretch: heading (unwrapped), its cosine and sine, `A` and the steer
/// angles.
#[derive(Clone, Copy)]
struct Node {
    psi: f64,
    cs: [f64; 2],
    a: [f64; MAX_CHANNELS],
    gamma: Steer,
    piece: Option<usize>,
}

impl Node {
    /// The node's heading (and path piece) as the hint of the next.
    fn hint(&self) -> Hint {
        Hint {
            psi: self.psi,
            cs: Some(self.cs),
            piece: self.piece,
        }
    }
}

/// One stretch of a move's grid between kinks: `cells` equal cells from `s0` to `s1`, its
/// `cells + 1` nodes from index `first` of the move's node vector.
struct Stretch {
    s0: f64,
    s1: f64,
    cells: usize,
    first: usize,
}

impl Stretch {
    /// The parameter of node `i` (the last exactly `s1`).
    fn sigma(&self, i: usize) -> f64 {
        let n = self.cells;
        if i >= n {
            self.s1
        } else {
            self.s0 + (self.s1 - self.s0) * i as f64 / n as f64
        }
    }

    /// The cell length.
    fn h(&self) -> f64 {
        (self.s1 - self.s0) / self.cells as f64
    }

    /// The stretch's nodes in the move's node vector `arena`.
    fn nodes<'a>(&self, arena: &'a [Node]) -> &'a [Node] {
        &arena[self.first..=self.first + self.cells]
    }

    /// The stretch's last node.
    fn last<'a>(&self, arena: &'a [Node]) -> &'a Node {
        &arena[self.first + self.cells]
    }

    /// Largest `|A|` and `|A'|` (central differences) per channel on the stretch (the first
    /// `chans` channels; the others stay 0).
    fn scale(&self, arena: &[Node], chans: usize) -> [[f64; MAX_CHANNELS]; 2] {
        let a = self.nodes(arena);
        let mut out = [[0.0_f64; MAX_CHANNELS]; 2];
        for row in a {
            for ch in 0..chans {
                // `if` rather than `max`: the same for NaN (ignored), fewer instructions.
                let v = row.a[ch].abs();
                if v > out[0][ch] {
                    out[0][ch] = v;
                }
            }
        }
        if a.len() >= 3 {
            let inv2h = 0.5 / self.h();
            for k in 1..a.len() - 1 {
                for ch in 0..chans {
                    let d = ((a[k + 1].a[ch] - a[k - 1].a[ch]) * inv2h).abs();
                    if d > out[1][ch] {
                        out[1][ch] = d;
                    }
                }
            }
        }
        out
    }

    /// Largest estimated error of linear interpolation between the nodes of `A`
    /// (`|Δ²A|/8 = h² A''/8`) and of its central differences `A'` (inside the stretch),
    /// relative to each channel's largest `|A|` and `|A'|` on the move (`scale`).
    fn error(&self, arena: &[Node], scale: &[[f64; MAX_CHANNELS]; 2], chans: usize) -> f64 {
        let nodes = self.nodes(arena);
        let a = |k: usize| &nodes[k].a;
        let m = nodes.len();
        if m < 3 {
            return 0.0;
        }
        let h = self.h();
        let inv = |s: f64, f: f64| if s > 0.0 { 1.0 / (f * s) } else { 0.0 };
        let inv_a: [f64; MAX_CHANNELS] = core::array::from_fn(|ch| inv(scale[0][ch], 8.0));
        // A'(k) = (A[k+1] − A[k−1]) / 2h, so Δ²A'/8 = (A[k+2] − 2A[k+1] + 2A[k−1] − A[k−2]) / 16h.
        let inv_b: [f64; MAX_CHANNELS] = core::array::from_fn(|ch| inv(scale[1][ch], 16.0 * h));
        let mut err = 0.0_f64;
        for k in 1..m - 1 {
            for ch in 0..chans {
                let e = (a(k - 1)[ch] - 2.0 * a(k)[ch] + a(k + 1)[ch]).abs() * inv_a[ch];
                if e > err {
                    err = e;
                }
            }
        }
        for k in 2..m.saturating_sub(2) {
            for ch in 0..chans {
                let d = a(k + 2)[ch] - 2.0 * a(k + 1)[ch] + 2.0 * a(k - 1)[ch] - a(k - 2)[ch];
                let e = d.abs() * inv_b[ch];
                if e > err {
                    err = e;
                }
            }
        }
        err
    }
}

/// Refuses a move grid of more than [`MAX_MOVE_GRID_CELLS`] cells (`n` per stretch).
fn too_many_cells(len: f64, n: &[usize]) -> Result<(), PlanningError> {
    let needed = n.iter().sum::<usize>();
    if needed > MAX_MOVE_GRID_CELLS {
        return Err(PlanningError::TooLarge {
            what: format!("a move of length {len:.4e} (m or rad)"),
            items: "grid cells",
            needed: needed as f64,
            limit: "MAX_MOVE_GRID_CELLS",
            max: MAX_MOVE_GRID_CELLS,
            hint: "shorten the path (--side, --radius, --turns, the waypoints) or cut it into \
                   several plans",
        });
    }
    Ok(())
}

/// Derivative of a vector function tabulated at the nodes `sig`, made of stretches of `n[j]`
/// equal cells: central differences inside a stretch, second-order one-sided differences at
/// the stretch ends (kinks, where the derivative may jump). Returns the derivative seen from
/// the cell ending at each node and from the cell starting there (equal except at kinks), in
/// the first `chans` channels or more (the others 0; fixed-length loops vectorise).
#[allow(clippy::type_complexity)]
fn derivative(
    a: &[[f64; MAX_CHANNELS]],
    sig: &[f64],
    n: &[usize],
    chans: usize,
) -> (Vec<[f64; MAX_CHANNELS]>, Vec<[f64; MAX_CHANNELS]>) {
    // Robots without steering use the first MAX_WHEELS channels only: half the work.
    if chans <= MAX_WHEELS {
        derivative_w::<MAX_WHEELS>(a, sig, n)
    } else {
        derivative_w::<MAX_CHANNELS>(a, sig, n)
    }
}

/// [`derivative`] of the first `W` channels (the others 0).
#[allow(clippy::type_complexity)]
fn derivative_w<const W: usize>(
    a: &[[f64; MAX_CHANNELS]],
    sig: &[f64],
    n: &[usize],
) -> (Vec<[f64; MAX_CHANNELS]>, Vec<[f64; MAX_CHANNELS]>) {
    let m = a.len();
    let widen = |d: [f64; W]| {
        let mut out = [0.0; MAX_CHANNELS];
        out[..W].copy_from_slice(&d);
        out
    };
    // Filled in node order (no zeroed buffers): a node is the end of one cell of some stretch
    // (`b_in`, nodes 1…m−1) and the start of one (`b_out`, nodes 0…m−2).
    let mut b_in = Vec::with_capacity(m);
    let mut b_out = Vec::with_capacity(m);
    b_in.push([0.0; MAX_CHANNELS]);
    let mut first = 0;
    for &c in n {
        let last = first + c;
        let h = (sig[last] - sig[first]) / c as f64;
        // One reciprocal a stretch, not a division a value (halving it is exact).
        let ih = 1.0 / h;
        let i2h = 0.5 * ih;
        for k in first..=last {
            let d: [f64; W] = if k > first && k < last {
                core::array::from_fn(|i| (a[k + 1][i] - a[k - 1][i]) * i2h)
            } else if c == 1 {
                core::array::from_fn(|i| (a[last][i] - a[first][i]) * ih)
            } else if k == first {
                core::array::from_fn(|i| (-3.0 * a[k][i] + 4.0 * a[k + 1][i] - a[k + 2][i]) * i2h)
            } else {
                core::array::from_fn(|i| (3.0 * a[k][i] - 4.0 * a[k - 1][i] + a[k - 2][i]) * i2h)
            };
            let d = widen(d);
            if k > first {
                b_in.push(d);
            }
            if k < last {
                b_out.push(d);
            }
        }
        first = last;
    }
    debug_assert_eq!((b_in.len(), b_out.len() + 1), (m, m));
    // The first node has no incoming cell and the last no outgoing one.
    b_in[0] = b_out[0];
    b_out.push(b_in[m - 1]);
    (b_in, b_out)
}
