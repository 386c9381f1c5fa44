//! Thinning long lines for drawing: at most [`MAX_FIGURE_POINTS`] points per line, keeping
//! each chunk's ends and extremes (spikes stay).

/// Most points drawn per polyline or band outline. A panel is ~700 px wide, so more points add
/// nothing visible and only grow the SVG: a plan of 10⁷ samples drew four 10⁷-point lines (a
/// 500 MB file and ~1.5 GB of memory). Longer lines are thinned to this many by [`decimate`];
/// 3 000 drew visible chords on a run of many laps, 10 000 does not.
pub const MAX_FIGURE_POINTS: usize = 10_000;

/// `points` thinned to at most [`MAX_FIGURE_POINTS`], in order, keeping the shape: the points
/// are cut into consecutive chunks, and each chunk keeps its first and last point and its
/// extremes in x and in y (so spikes and the outline stay where they are). O(n). Shorter lines
/// are returned as they are. [`Decimator`] does the same one point at a time.
pub fn decimate(points: &[(f64, f64)]) -> std::borrow::Cow<'_, [(f64, f64)]> {
    if points.len() <= MAX_FIGURE_POINTS {
        return std::borrow::Cow::Borrowed(points);
    }
    let mut d = Decimator::new(points.len());
    for &p in points {
        d.push(p);
    }
    std::borrow::Cow::Owned(d.finish())
}

/// [`decimate`] of a line whose points come one at a time (a log too long to hold), given
/// their number `n` up front: it keeps the same points, holding one chunk (at most
/// `n / 1 666 + 1` points) and the result (at most [`MAX_FIGURE_POINTS`]). Points beyond `n`
/// are thinned in further chunks of the same size; a line of at most [`MAX_FIGURE_POINTS`] is
/// kept whole.
#[derive(Clone, Debug)]
pub struct Decimator {
    /// Points per chunk (`usize::MAX`: keep every point).
    chunk: usize,
    part: Vec<(f64, f64)>,
    out: Vec<(f64, f64)>,
}

impl Decimator {
    /// A decimator for a line of `n` points. With `n` ≤ [`MAX_FIGURE_POINTS`] (0 when the
    /// number is not known) every point is kept, for [`decimate`] to thin when drawn.
    pub fn new(n: usize) -> Self {
        let chunk = if n <= MAX_FIGURE_POINTS {
            usize::MAX
        } else {
            n.div_ceil(MAX_FIGURE_POINTS / 6)
        };
        Self {
            chunk,
            part: Vec::new(),
            out: Vec::new(),
        }
    }

    /// Takes the next point of the line.
    pub fn push(&mut self, p: (f64, f64)) {
        if self.chunk == usize::MAX {
            self.out.push(p);
            return;
        }
        self.part.push(p);
        if self.part.len() == self.chunk {
            keep_extremes(&self.part, &mut self.out);
            self.part.clear();
        }
    }

    /// The thinned line.
    pub fn finish(mut self) -> Vec<(f64, f64)> {
        if !self.part.is_empty() {
            keep_extremes(&self.part, &mut self.out);
        }
        self.out
    }
}

/// Appends to `out` the first and last points of `part` and its extremes in x and y, in order
/// and once each.
fn keep_extremes(part: &[(f64, f64)], out: &mut Vec<(f64, f64)>) {
    let arg = |key: fn(&(f64, f64)) -> f64, better: fn(f64, f64) -> bool| {
        let mut best = 0;
        for (i, p) in part.iter().enumerate() {
            if better(key(p), key(&part[best])) {
                best = i;
            }
        }
        best
    };
    let mut keep = [
        0,
        part.len() - 1,
        arg(|p| p.0, |a, b| a < b),
        arg(|p| p.0, |a, b| a > b),
        arg(|p| p.1, |a, b| a < b),
        arg(|p| p.1, |a, b| a > b),
    ];
    keep.sort_unstable();
    let mut last = usize::MAX;
    for i in keep {
        if i != last {
            out.push(part[i]);
            last = i;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_bounds_the_points_and_keeps_ends_and_extremes() {
        let n = 1_000_003;
        let mut pts: Vec<(f64, f64)> = (0..n)
            .map(|k| {
                let t = k as f64 * 1e-3;
                (t, (t * 0.7).sin())
            })
            .collect();
        pts[123_457] = (123.457, 5.0); // a one-sample spike
        pts[654_321] = (654.321, -7.0);
        let d = decimate(&pts);
        assert!(d.len() <= MAX_FIGURE_POINTS, "{}", d.len());
        assert_eq!(d.first(), pts.first());
        assert_eq!(d.last(), pts.last());
        assert!(d.contains(&(123.457, 5.0)) && d.contains(&(654.321, -7.0)));
        // In order: time never goes back.
        assert!(d.windows(2).all(|w| w[0].0 < w[1].0));
        let short = &pts[..MAX_FIGURE_POINTS];
        assert_eq!(&*decimate(short), short);
    }
}
