//! Scoring an estimated trajectory against ground truth: the absolute trajectory error (ATE)
//! and the relative pose error (RPE) of Sturm et al., "A Benchmark for the Evaluation of RGB-D
//! SLAM Systems", IROS 2012 (the TUM RGB-D benchmark), §V, written for poses in SE(2).
//!
//! * **Time association**: the truth is interpolated linearly (x, y and the unwrapped
//!   heading) at each estimate's time. Estimates before the truth's first or after its last
//!   sample are not scored and are counted ([`RunErrors::outside_truth`]); when none overlap,
//!   the run is refused ([`PoseErrorError::NoOverlap`]).
//! * **ATE** (Sturm eq. 2): the position error `|trans(Q_i⁻¹ S P_i)|` per associated sample,
//!   with `S` the alignment: none by default (a robot that knows its start pose is scored in
//!   the truth's frame as it is), or the least-squares rigid motion in the plane
//!   ([`Alignment::Se2`], Umeyama 1991 / Horn 1987 in 2-D, closed form).
//! * **RPE** (Sturm eq. 1): for each sample `i` and the first sample `j` at least Δ later
//!   (in time, or in distance travelled along the truth), the error of the estimate's
//!   motion `E = (Q_i⁻¹ Q_j)⁻¹ (P_i⁻¹ P_j)`: its translation (m) and its rotation angle
//!   (rad). RPE does not depend on the alignment; it needs headings in both files.
//!
//! Statistics are RMS, mean, median and max ([`ErrorStats`]); [`summarize`] pools several runs
//! (every sample of every run counts once). Cost: O(n + m) for the association and the RPE
//! pairs (two monotone walks), O(n log n) for the medians.

use serde::Serialize;

use crate::track::Track;

/// How the estimate is put in the truth's frame before the ATE.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum Alignment {
    /// None: the estimate is compared as it is (the robot knew its start pose).
    #[default]
    None,
    /// The rotation and translation in the plane that minimise the sum of squared position
    /// errors (Umeyama 1991, Horn 1987; no scale).
    Se2,
}

/// The step of the relative pose error.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RpeDelta {
    /// Pairs of samples Δ seconds apart (the first sample at least Δ − 1 µs later).
    TimeS(f64),
    /// Pairs of samples Δ metres apart along the truth's path.
    DistanceM(f64),
}

impl Default for RpeDelta {
    /// One second, the TUM benchmark's default for odometry ("drift per second").
    fn default() -> Self {
        Self::TimeS(1.0)
    }
}

/// What the evaluation is asked to do.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct PoseErrorOptions {
    /// Alignment before the ATE.
    pub alignment: Alignment,
    /// Step of the RPE.
    pub rpe_delta: RpeDelta,
}

/// Why an estimate cannot be scored against the truth.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PoseErrorError {
    /// The estimate's times and the truth's do not overlap.
    #[error(
        "the times do not overlap: the estimate covers t = {estimate_s:?} s, the truth \
         t = {truth_s:?} s; both must be on the same clock"
    )]
    NoOverlap {
        /// First and last time of the estimate, s.
        estimate_s: [f64; 2],
        /// First and last time of the truth, s.
        truth_s: [f64; 2],
    },
    /// The RPE step is not a positive finite number.
    #[error("the RPE step must be a positive finite number (got {0})")]
    BadDelta(f64),
}

/// RMS, mean, median and maximum of a set of non-negative errors.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ErrorStats {
    /// Number of errors.
    pub count: usize,
    /// Root mean square.
    pub rms: f64,
    /// Mean.
    pub mean: f64,
    /// Median (the mean of the middle two for an even count).
    pub median: f64,
    /// Maximum.
    pub max: f64,
}

impl ErrorStats {
    /// The statistics of `errors` (sorted in place for the median); `None` when empty.
    pub fn of(errors: &mut [f64]) -> Option<Self> {
        let n = errors.len();
        if n == 0 {
            return None;
        }
        errors.sort_unstable_by(f64::total_cmp);
        let sum: f64 = errors.iter().sum();
        let sq: f64 = errors.iter().map(|e| e * e).sum();
        let median = if n % 2 == 1 {
            errors[n / 2]
        } else {
            0.5 * (errors[n / 2 - 1] + errors[n / 2])
        };
        Some(Self {
            count: n,
            rms: (sq / n as f64).sqrt(),
            mean: sum / n as f64,
            median,
            max: errors[n - 1],
        })
    }
}

/// The alignment that was applied: estimate ↦ R(rotation) · estimate + translation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct AppliedAlignment {
    /// Which alignment.
    pub kind: Alignment,
    /// Rotation, rad (0 without alignment).
    pub rotation_rad: f64,
    /// Translation, m (0 without alignment).
    pub translation_m: [f64; 2],
}

/// One run's errors against the truth, sample by sample.
#[derive(Clone, Debug, PartialEq)]
pub struct RunErrors {
    /// The alignment applied before the ATE.
    pub alignment: AppliedAlignment,
    /// Estimate samples outside the truth's time span (not scored).
    pub outside_truth: usize,
    /// ATE: position error per associated sample, m.
    pub ate_m: Vec<f64>,
    /// Heading error per associated sample after the alignment, rad, wrapped to [0, π]
    /// (when both files have headings).
    pub heading_rad: Option<Vec<f64>>,
    /// RPE, translational part, m, one per pair.
    pub rpe_translation_m: Vec<f64>,
    /// RPE, rotational part, rad, one per pair.
    pub rpe_rotation_rad: Vec<f64>,
}

/// The statistics of one run or of several pooled.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PoseErrorSummary {
    /// Scored samples (estimate samples inside the truth's time span).
    pub samples: usize,
    /// Estimate samples outside the truth's time span.
    pub outside_truth: usize,
    /// ATE, position, m.
    pub ate_m: Option<ErrorStats>,
    /// Heading error after the alignment, rad (when both files have headings).
    pub heading_error_rad: Option<ErrorStats>,
    /// RPE, translational, m (`None` when no pair is Δ apart or a heading is missing).
    pub rpe_translation_m: Option<ErrorStats>,
    /// RPE, rotational, rad.
    pub rpe_rotation_rad: Option<ErrorStats>,
}

impl Alignment {
    /// The alignment in words (`evaluate --truth`'s header line).
    pub fn describe(self) -> &'static str {
        match self {
            Alignment::None => "none (the estimate's start pose is known)",
            Alignment::Se2 => "se2 (least-squares rotation and translation)",
        }
    }
}

impl RpeDelta {
    /// `Δ = 1 s` or `Δ = 0.5 m`.
    pub fn describe(self) -> String {
        match self {
            RpeDelta::TimeS(t) => format!("Δ = {t} s"),
            RpeDelta::DistanceM(d) => format!("Δ = {d} m"),
        }
    }
}

/// `rms R, mean M, median D, max X` in mm or mrad (`—` without values).
fn stats_text(s: &Option<ErrorStats>, unit: &str) -> String {
    match s {
        Some(s) => format!(
            "rms {:.1}, mean {:.1}, median {:.1}, max {:.1} {unit}",
            1e3 * s.rms,
            1e3 * s.mean,
            1e3 * s.median,
            1e3 * s.max
        ),
        None => "—".into(),
    }
}

impl PoseErrorSummary {
    /// Two lines for a person, each starting with `name`: the ATE and heading error (mm,
    /// mrad), then the RPE's translation and rotation over its pairs.
    pub fn lines(&self, name: &str) -> [String; 2] {
        [
            format!(
                "{name}: {} samples; ATE {}; heading error {}",
                self.samples,
                stats_text(&self.ate_m, "mm"),
                stats_text(&self.heading_error_rad, "mrad")
            ),
            format!(
                "{name}: RPE over {} pairs: translation {}; rotation {}",
                self.rpe_translation_m.map_or(0, |r| r.count),
                stats_text(&self.rpe_translation_m, "mm"),
                stats_text(&self.rpe_rotation_rad, "mrad")
            ),
        ]
    }
}

impl RunErrors {
    /// This run's statistics.
    pub fn summary(&self) -> PoseErrorSummary {
        summarize(core::slice::from_ref(self))
    }
}

/// The statistics of several runs, every sample (and RPE pair) of every run counting once.
pub fn summarize(runs: &[RunErrors]) -> PoseErrorSummary {
    let pool = |f: &dyn Fn(&RunErrors) -> &[f64]| -> Option<ErrorStats> {
        let mut v: Vec<f64> = runs.iter().flat_map(|r| f(r).iter().copied()).collect();
        ErrorStats::of(&mut v)
    };
    let all_headings = runs.iter().all(|r| r.heading_rad.is_some());
    PoseErrorSummary {
        samples: runs.iter().map(|r| r.ate_m.len()).sum(),
        outside_truth: runs.iter().map(|r| r.outside_truth).sum(),
        ate_m: pool(&|r| &r.ate_m),
        heading_error_rad: if all_headings {
            pool(&|r| r.heading_rad.as_deref().unwrap_or(&[]))
        } else {
            None
        },
        rpe_translation_m: pool(&|r| &r.rpe_translation_m),
        rpe_rotation_rad: pool(&|r| &r.rpe_rotation_rad),
    }
}

/// A pose in the plane: x, y (m), heading (rad; `None` when the file has none).
#[derive(Clone, Copy, Debug)]
struct Pose {
    x: f64,
    y: f64,
    h: Option<f64>,
}

/// Scores `estimate` against `truth` (see the module documentation).
pub fn evaluate_run(
    truth: &Track,
    estimate: &Track,
    options: &PoseErrorOptions,
) -> Result<RunErrors, PoseErrorError> {
    let delta = match options.rpe_delta {
        RpeDelta::TimeS(d) | RpeDelta::DistanceM(d) => d,
    };
    if !(delta.is_finite() && delta > 0.0) {
        return Err(PoseErrorError::BadDelta(delta));
    }
    let Associated {
        range,
        truth_at,
        outside_truth,
    } = associate(truth, estimate)?;
    let times = &estimate.t[range.clone()];
    let est: Vec<Pose> = range
        .map(|k| Pose {
            x: estimate.xy[k][0],
            y: estimate.xy[k][1],
            h: estimate.heading.as_ref().map(|h| h[k]),
        })
        .collect();
    // Alignment: estimate ↦ R est + t.
    let alignment = match options.alignment {
        Alignment::None => AppliedAlignment::default(),
        Alignment::Se2 => se2_alignment(&est, &truth_at),
    };
    let (s, c) = alignment.rotation_rad.sin_cos();
    let [tx, ty] = alignment.translation_m;
    let mut ate_m = Vec::with_capacity(est.len());
    let mut heading_rad = Some(Vec::with_capacity(est.len()));
    for (p, q) in est.iter().zip(&truth_at) {
        let x = c * p.x - s * p.y + tx;
        let y = s * p.x + c * p.y + ty;
        ate_m.push((x - q.x).hypot(y - q.y));
        heading_rad = match (heading_rad, p.h, q.h) {
            (Some(mut v), Some(ph), Some(qh)) => {
                v.push(omnikin::wrap_angle(ph + alignment.rotation_rad - qh).abs());
                Some(v)
            }
            _ => None,
        };
    }
    let (rpe_translation_m, rpe_rotation_rad) = if heading_rad.is_some() {
        rpe(&est, &truth_at, times, options.rpe_delta)
    } else {
        (Vec::new(), Vec::new())
    };
    Ok(RunErrors {
        alignment,
        outside_truth,
        ate_m,
        heading_rad,
        rpe_translation_m,
        rpe_rotation_rad,
    })
}

/// The estimate samples inside the truth's time span and the truth at their times.
struct Associated {
    /// Indices of the estimate samples kept (contiguous: both files are sorted by time).
    range: core::ops::Range<usize>,
    /// The truth interpolated at each kept sample's time.
    truth_at: Vec<Pose>,
    /// Estimate samples outside the truth's span.
    outside_truth: usize,
}

/// Time association: the truth interpolated linearly at each estimate time in its span
/// (one monotone walk over both files, O(n + m)).
fn associate(truth: &Track, estimate: &Track) -> Result<Associated, PoseErrorError> {
    let span = |t: &[f64]| [t[0], t[t.len() - 1]];
    let (t0, t1) = (truth.t[0], truth.t[truth.t.len() - 1]);
    let lo = estimate.t.partition_point(|&t| t < t0);
    let hi = estimate.t.partition_point(|&t| t <= t1);
    if lo >= hi {
        return Err(PoseErrorError::NoOverlap {
            estimate_s: span(&estimate.t),
            truth_s: span(&truth.t),
        });
    }
    let mut truth_at = Vec::with_capacity(hi - lo);
    let mut k = 0; // truth segment [k, k + 1] holding the current time
    for &t in &estimate.t[lo..hi] {
        while k + 2 < truth.t.len() && truth.t[k + 1] < t {
            k += 1;
        }
        let (ta, tb) = (truth.t[k], truth.t[k + 1]);
        // ta < tb (strictly increasing times); t in [ta, tb], except for a one-sample truth,
        // which Track refuses.
        let a = ((t - ta) / (tb - ta)).clamp(0.0, 1.0);
        let lerp = |u: f64, v: f64| u + a * (v - u);
        let (pa, pb) = (truth.xy[k], truth.xy[k + 1]);
        truth_at.push(Pose {
            x: lerp(pa[0], pb[0]),
            y: lerp(pa[1], pb[1]),
            h: truth.heading.as_ref().map(|h| lerp(h[k], h[k + 1])),
        });
    }
    Ok(Associated {
        range: lo..hi,
        truth_at,
        outside_truth: estimate.t.len() - (hi - lo),
    })
}

/// The rigid motion in the plane that best maps `p` onto `q` in least squares (Umeyama 1991,
/// Horn 1987, 2-D): with the centroids removed, the rotation is
/// `atan2(Σ p × q, Σ p · q)` and the translation `q̄ − R p̄`.
fn se2_alignment(p: &[Pose], q: &[Pose]) -> AppliedAlignment {
    let n = p.len() as f64;
    let mean = |v: &[Pose]| {
        let (sx, sy) = v.iter().fold((0.0, 0.0), |(a, b), s| (a + s.x, b + s.y));
        (sx / n, sy / n)
    };
    let ((pxm, pym), (qxm, qym)) = (mean(p), mean(q));
    let (mut cross, mut dot) = (0.0, 0.0);
    for (a, b) in p.iter().zip(q) {
        let (ax, ay, bx, by) = (a.x - pxm, a.y - pym, b.x - qxm, b.y - qym);
        cross += ax * by - ay * bx;
        dot += ax * bx + ay * by;
    }
    // All points on one spot (no rotation is defined): translation only.
    let rotation = if cross == 0.0 && dot == 0.0 {
        0.0
    } else {
        cross.atan2(dot)
    };
    let (s, c) = rotation.sin_cos();
    AppliedAlignment {
        kind: Alignment::Se2,
        rotation_rad: rotation,
        translation_m: [qxm - (c * pxm - s * pym), qym - (s * pxm + c * pym)],
    }
}

/// `a⁻¹ b` in SE(2): the motion from `a` to `b` in `a`'s frame (x, y, angle). Headings are
/// present (checked by the caller).
fn between(a: &Pose, b: &Pose) -> (f64, f64, f64) {
    let (ha, hb) = (a.h.unwrap_or(0.0), b.h.unwrap_or(0.0));
    let (s, c) = ha.sin_cos();
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    (c * dx + s * dy, -s * dx + c * dy, hb - ha)
}

/// RPE pairs: for each `i`, the first `j` at least Δ later (time, or distance along the
/// truth), and the error `E = (Q_i⁻¹ Q_j)⁻¹ (P_i⁻¹ P_j)` (one monotone walk, O(n)).
fn rpe(est: &[Pose], truth: &[Pose], t: &[f64], delta: RpeDelta) -> (Vec<f64>, Vec<f64>) {
    let (key, step): (Vec<f64>, f64) = match delta {
        RpeDelta::TimeS(d) => (t.to_vec(), d - 1e-6),
        RpeDelta::DistanceM(d) => {
            let mut s = Vec::with_capacity(truth.len());
            let mut acc = 0.0;
            for (k, q) in truth.iter().enumerate() {
                if k > 0 {
                    acc += (q.x - truth[k - 1].x).hypot(q.y - truth[k - 1].y);
                }
                s.push(acc);
            }
            (s, d * (1.0 - 1e-9))
        }
    };
    let (mut trans, mut rot) = (Vec::new(), Vec::new());
    let mut j = 0;
    for i in 0..est.len() {
        j = j.max(i + 1);
        while j < est.len() && key[j] - key[i] < step {
            j += 1;
        }
        if j == est.len() {
            break;
        }
        let (qx, qy, qa) = between(&truth[i], &truth[j]);
        let (px, py, pa) = between(&est[i], &est[j]);
        // E = Dq⁻¹ Dp: translation R(−qa)(p − q), angle pa − qa.
        let (s, c) = qa.sin_cos();
        let (ex, ey) = (px - qx, py - qy);
        trans.push((c * ex + s * ey).hypot(-s * ex + c * ey));
        rot.push(omnikin::wrap_angle(pa - qa).abs());
    }
    (trans, rot)
}

#[cfg(test)]
mod tests;
