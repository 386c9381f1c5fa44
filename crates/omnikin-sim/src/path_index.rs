//! Exact nearest-segment distances to a polyline for many query points: a bounding-box tree
//! over the path's segments, split in space (a k-d tree of segments).
//!
//! [`crate::metrics::distance_to_path`] scans every segment, O(n) per point; evaluating n
//! points that way is O(n²) (100 000 rows took minutes). [`PathIndex`] is built once in
//! O(n log n): each node's segments are split in two halves at the median of their midpoints
//! along the longer side of the node's box. A query is a branch and bound: it visits a node
//! only when its box could hold a segment nearer than the best one found so far. Consecutive
//! samples of a run are near consecutive parts of the path, so a query is seeded with the
//! previous answer's segment ([`PathIndex::nearest`]) and typically touches O(log n) nodes.
//!
//! **Exact**: the leaves compute each segment's distance with the same expression as
//! [`crate::metrics::distance_to_path`], and a box is skipped only when even its distance minus
//! a bound on the floating-point rounding of both computations exceeds the best distance, so
//! the minimum over the visited segments is the minimum over all of them, bit for bit
//! (property-tested against the exhaustive scan). Non-finite inputs disable pruning, so they
//! give the exhaustive scan's answer too.
//!
//! **Cost**: O(n) memory, O(n log n) build. A query is O(log n) when few parts of the path are nearly
//! as near as the nearest one; a point about equally far from a long stretch of the path (the
//! centre of a circular plan) must look at that whole stretch, as any exact method must. So
//! must a point inside a dense noisy polyline (a run's tracked positions at a high rate: each
//! segment jumps across the noise band, so the boxes of all segments within the band's width
//! hold the point, O(rate) of them). The largest distance of many points — the metric "plan
//! farthest from a run" — does not need each point's exact distance:
//! [`PathIndex::farthest`] stops a point's search at the first segment within the largest
//! distance found so far (an early-break directed Hausdorff search), which on such a run is
//! usually the first segment tried. `reproduce --profiles hardware --trials 1 --threads 1`:
//! 0.71 → 0.28 s at 1.6 kHz, 1.84 → 0.53 s at 3.2 kHz, 1.15 s at 6.4 kHz (the same output
//! files).

/// Segments per leaf.
const LEAF: usize = 8;

/// Entries of a query's node stack. The search goes down nearer child first, leaving one
/// sibling per level on the stack, so it holds at most the tree's height + 1 entries; the
/// tree halves the segment range per level, so 48 entries serve every path of up to
/// `LEAF · 2^46` segments or more (far beyond memory). A deeper node would be scanned directly
/// (still exact). The stack is zeroed per query: at 130 entries (2 kB, enough for any
/// `usize`) the zeroing was a fifth of a query's instructions.
const STACK: usize = 48;

#[derive(Clone, Copy, Debug)]
struct Node {
    /// Box of the node's vertices, m.
    lo: [f64; 2],
    hi: [f64; 2],
    /// Range `start..end` of `PathIndex::order`: the node's segments.
    start: usize,
    end: usize,
    /// Children (indices into `nodes`), `None` for a leaf.
    children: Option<(usize, usize)>,
}

/// A polyline prepared for exact nearest-segment distance queries (see the module docs).
#[derive(Clone, Debug)]
pub struct PathIndex {
    path: Vec<[f64; 2]>,
    /// Segment indices (segment `i` joins vertices `i` and `i + 1`), grouped by node.
    order: Vec<usize>,
    nodes: Vec<Node>,
    /// Largest |coordinate| of the path, m: scales the rounding margin of the pruning test.
    scale: f64,
}

/// Squared distance from `p` to segment `a`–`b`, computed exactly as the exhaustive scan does.
#[inline]
fn segment_d2(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    let s = if len2 > 0.0 {
        (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p[0] - a[0] - s * dx).powi(2) + (p[1] - a[1] - s * dy).powi(2)
}

/// Squared distance from `p` to the box `lo`–`hi` (0 inside).
#[inline]
fn box_d2(p: [f64; 2], lo: [f64; 2], hi: [f64; 2]) -> f64 {
    let dx = (lo[0] - p[0]).max(p[0] - hi[0]).max(0.0);
    let dy = (lo[1] - p[1]).max(p[1] - hi[1]).max(0.0);
    dx * dx + dy * dy
}

impl PathIndex {
    /// Indexes the polyline through `path` (m, any frame). O(n log n) time, O(n) memory.
    pub fn new(path: &[[f64; 2]]) -> Self {
        let mut index = Self {
            path: path.to_vec(),
            order: (0..path.len().saturating_sub(1)).collect(),
            nodes: Vec::with_capacity(2 * path.len() / LEAF + 2),
            scale: path
                .iter()
                .flat_map(|p| p.iter().map(|c| c.abs()))
                .fold(0.0, f64::max),
        };
        if path.len() >= 2 {
            index.build(0, path.len() - 1);
        }
        index
    }

    /// Number of vertices of the indexed path.
    pub fn len(&self) -> usize {
        self.path.len()
    }

    /// Whether the indexed path has no vertex.
    pub fn is_empty(&self) -> bool {
        self.path.is_empty()
    }

    /// Builds the node of the segments `order[start..end]` (non-empty) and returns its index.
    fn build(&mut self, start: usize, end: usize) -> usize {
        let id = self.nodes.len();
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for &i in &self.order[start..end] {
            for v in [self.path[i], self.path[i + 1]] {
                for c in 0..2 {
                    lo[c] = lo[c].min(v[c]);
                    hi[c] = hi[c].max(v[c]);
                }
            }
        }
        self.nodes.push(Node {
            lo,
            hi,
            start,
            end,
            children: None,
        });
        if end - start > LEAF {
            // Split at the median of the segments' midpoints along the box's longer side, so
            // that the boxes are tight in space (laps of the same circuit fall apart).
            let axis = usize::from(hi[1] - lo[1] > hi[0] - lo[0]);
            let mid = start + (end - start) / 2;
            let path = &self.path;
            self.order[start..end].select_nth_unstable_by(mid - start, |&a, &b| {
                let ka = path[a][axis] + path[a + 1][axis];
                let kb = path[b][axis] + path[b + 1][axis];
                ka.total_cmp(&kb)
            });
            let (l, r) = (self.build(start, mid), self.build(mid, end));
            self.nodes[id].children = Some((l, r));
        }
        id
    }

    /// Distance from `p` to the indexed polyline, m: the same value as
    /// [`crate::metrics::distance_to_path`] (∞ for an empty path).
    pub fn distance(&self, p: [f64; 2]) -> f64 {
        self.nearest(p, 0).0
    }

    /// Distance from `p` to the polyline, m, and the index of a nearest segment (segment `i`
    /// joins vertices `i` and `i + 1`; 0 for a path of fewer than two vertices). `hint` is a
    /// segment to try first (e.g. the previous sample's answer); any value is correct, a good
    /// one makes the query faster.
    pub fn nearest(&self, p: [f64; 2], hint: usize) -> (f64, usize) {
        let path = &self.path;
        match path.len() {
            0 => return (f64::INFINITY, 0),
            1 => return ((p[0] - path[0][0]).hypot(p[1] - path[0][1]), 0),
            _ => {}
        }
        let (best, arg) = self.search(p, hint, f64::NEG_INFINITY);
        (best.sqrt(), arg)
    }

    /// The largest distance of `points` from the polyline, m: exactly
    /// `points.map(|p| self.distance(p)).fold(0.0, f64::max)` (0 for no points), by an
    /// early-break directed Hausdorff search (Taha & Hanbury, "An efficient algorithm for
    /// calculating the exact Hausdorff distance", IEEE TPAMI 2015): a point whose distance to
    /// some segment (first the one the previous point's search ended on, then any the search
    /// meets) is already within the largest distance found cannot raise it, so its search
    /// stops there. Points
    /// along a path close to the polyline mostly stop at the first segment tried; a query that
    /// must be exact costs what [`PathIndex::nearest`] costs, which on a dense noisy polyline
    /// grows with its number of segments near the point.
    pub fn farthest(&self, points: &[[f64; 2]]) -> f64 {
        let path = &self.path;
        if path.len() < 2 {
            return points.iter().map(|&p| self.distance(p)).fold(0.0, f64::max);
        }
        // Squared distances as the search computes them; the answer is the square root of the
        // largest, as `nearest` takes it.
        let (mut worst, mut hint) = (0.0_f64, 0);
        for &p in points {
            let (d2, arg) = self.search(p, hint, worst);
            hint = arg;
            if d2 > worst {
                worst = d2;
            }
        }
        worst.sqrt()
    }

    /// The branch and bound of [`PathIndex::nearest`] (`path` has ≥ 2 vertices): the squared
    /// distance of the nearest segment and its index; it returns early, with a segment whose
    /// squared distance is `≤ stop`, once one is found (`stop = −∞`: never).
    fn search(&self, p: [f64; 2], hint: usize, stop: f64) -> (f64, usize) {
        let path = &self.path;
        let segments = path.len() - 1;
        let hint = hint.min(segments - 1);
        // As in the exhaustive scan, a NaN distance never becomes the best.
        let (mut best, mut arg) = (f64::INFINITY, hint);
        let d = segment_d2(p, path[hint], path[hint + 1]);
        if d < best {
            best = d;
        }
        if best <= stop {
            return (best, arg);
        }
        // Rounding margin, m: both the box distance and a segment's computed distance are
        // within a few ulps of the coordinates' magnitude of the true ones; 32 ulps of
        // |p| + 2 × the path's largest coordinate bounds both with room to spare. A box is
        // skipped only when its squared distance exceeds (√best + margin)² (1 + 1e-12): then
        // no segment in it can compute below `best`. NaN anywhere makes the test false, so
        // nothing is skipped.
        let margin = 32.0 * f64::EPSILON * (p[0].abs() + p[1].abs() + 2.0 * self.scale);
        let bound = |best: f64| (best.sqrt() + margin).powi(2) * (1.0 + 1e-12);
        let mut limit = bound(best);
        let mut stack = [(0usize, 0.0f64); STACK];
        let mut top = 1usize;
        stack[0] = (0, box_d2(p, self.nodes[0].lo, self.nodes[0].hi));
        while top > 0 {
            top -= 1;
            let (id, d2) = stack[top];
            if d2 > limit {
                continue;
            }
            let node = &self.nodes[id];
            // A full stack (a tree deeper than any path in memory, see STACK) scans the node's
            // segments directly.
            let children = node.children.filter(|_| top + 2 <= STACK);
            match children {
                None => {
                    for &i in &self.order[node.start..node.end] {
                        let d = segment_d2(p, path[i], path[i + 1]);
                        if d < best {
                            best = d;
                            arg = i;
                        }
                    }
                    if best <= stop {
                        return (best, arg);
                    }
                    limit = bound(best);
                }
                Some((l, r)) => {
                    let dl = box_d2(p, self.nodes[l].lo, self.nodes[l].hi);
                    let dr = box_d2(p, self.nodes[r].lo, self.nodes[r].hi);
                    // The nearer child on top, so it is searched first.
                    let (near, far) = if dl <= dr {
                        ((l, dl), (r, dr))
                    } else {
                        ((r, dr), (l, dl))
                    };
                    stack[top] = far;
                    stack[top + 1] = near;
                    top += 2;
                }
            }
        }
        (best, arg)
    }
}
