//! The residual of a sample (the lowest drop over the motions that can
//! reach its line) and of the whole grid, in parallel over tiles of samples
//! whose candidate motions are listed once per tile.

use super::motion_index::Scratch;
use super::reach::{segment_distance, ReachLine};
use super::simulator::{Frame, Simulator};
use nalgebra::Vector3;
use toolpath_kernel::error::Error;
use toolpath_kernel::progress::Progress;

/// Which residual a run uses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Method {
    Fast,
    /// Every candidate motion scanned and refined in full.
    #[cfg(feature = "reference")]
    Reference,
}

impl Simulator<'_> {
    /// Residual at surface point `p` with tool-side unit normal `n`; `None` if uncovered.
    pub(super) fn residual(
        &self,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        scratch: &mut Vec<u32>,
    ) -> Option<f64> {
        self.candidates_sorted(p, n, scratch);
        self.residual_of(p, n, scratch).0
    }

    /// The box of the line p + t n over the searched range [-depth, cap].
    pub(super) fn line_box(
        &self,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
    ) -> (Vector3<f64>, Vector3<f64>) {
        let a = p - n * self.depth;
        let b = p + n * self.cap;
        let pad = Vector3::repeat(1e-9);
        (a.inf(&b) - pad, a.sup(&b) + pad)
    }

    /// Ids of the motions whose cells meet the line's box, sorted, once each.
    pub(super) fn candidates_sorted(&self, p: &Vector3<f64>, n: &Vector3<f64>, out: &mut Vec<u32>) {
        let (lo, hi) = self.line_box(p, n);
        out.clear();
        self.index.query(&lo, &hi, out);
        out.sort_unstable();
        out.dedup();
    }

    /// Ids of the motions whose cells meet the line's box, once each (marked
    /// in a per-motion stamp array instead of sorted), the motion that was
    /// lowest at the previous sample first: neighbouring samples are mostly cut
    /// by the same motion, so its drop makes the cutoff for the others tight.
    pub(super) fn candidates_stamped(&self, p: &Vector3<f64>, n: &Vector3<f64>, sc: &mut Scratch) {
        let (lo, hi) = self.line_box(p, n);
        self.index.collect_stamped(&lo, &hi, sc);
        if let Some(pos) = sc
            .last_best
            .and_then(|b| sc.ids.iter().position(|&id| id == b))
        {
            sc.ids.swap(0, pos);
        }
    }

    /// The motions of a tile of samples (their frames): those whose own box
    /// meets the box of all the tile's lines, once each, into `sc.ids`.
    pub(super) fn tile_candidates<'f>(
        &self,
        frames: impl Iterator<Item = &'f (Vector3<f64>, Vector3<f64>, f64)> + Clone,
        sc: &mut Scratch,
    ) {
        let mut lo = Vector3::repeat(f64::INFINITY);
        let mut hi = Vector3::repeat(f64::NEG_INFINITY);
        for (p, n, _) in frames.clone() {
            let (a, b) = self.line_box(p, n);
            lo = lo.inf(&a);
            hi = hi.sup(&b);
        }
        sc.ids.clear();
        if lo.x <= hi.x {
            self.index.collect_stamped(&lo, &hi, sc);
        }
        // Every line of the tile lies within `rho` of the mean line (the
        // distance to a segment is convex, so its ends bound it): a motion
        // whose axis stays further than R + margin + rho from the mean line
        // fails `may_reach` at every sample of the tile.
        let (mut pc, mut nc, mut count) = (Vector3::zeros(), Vector3::zeros(), 0.0);
        for (p, n, _) in frames.clone() {
            pc += p;
            nc += n;
            count += 1.0;
        }
        let Some(nc) = nc.try_normalize(1e-12) else {
            return;
        };
        pc /= count;
        let (a, b) = (pc - nc * self.depth, pc + nc * self.cap);
        let mut rho: f64 = 0.0;
        for (p, n, _) in frames {
            for q in [p - n * self.depth, p + n * self.cap] {
                rho = rho.max(segment_distance(&q, &q, &a, &b));
            }
        }
        rho += 1e-9 * (self.depth + self.cap);
        let (motions, radius) = (&self.motions, self.cutter.radius);
        let mean = ReachLine::new(&pc, &nc, self.depth, self.cap);
        sc.ids.retain(|&id| {
            motions.get(id as usize).is_some_and(|seg| {
                let reach = radius + seg.margin + rho;
                mean.distance2_to_mid_axis(seg) <= reach * reach
            })
        });
    }

    /// The fast residual of a sample of the tile whose candidates are in
    /// `sc.ids`: those whose box meets the sample's line box, the previous
    /// sample's lowest motion first.
    pub(super) fn residual_in_tile(
        &self,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        sc: &mut Scratch,
    ) -> Option<f64> {
        let (lo, hi) = self.line_box(p, n);
        let meets = |id: u32| self.index.meets(id, &lo, &hi);
        let first = sc.last_best.filter(|&b| meets(b));
        let line = ReachLine::new(p, n, self.depth, self.cap);
        let mut best = f64::INFINITY;
        let mut lowest = None;
        let rest = sc.ids.iter().copied().filter(|&id| Some(id) != first);
        for id in first.into_iter().chain(rest) {
            if Some(id) != first && !meets(id) {
                continue;
            }
            self.consider(id, &line, p, n, &mut best, &mut lowest);
        }
        if lowest.is_some() {
            sc.last_best = lowest;
        }
        (best <= self.cap).then_some(best)
    }

    /// Lowers `best` (and sets `lowest`) to the drop of motion `id` if below.
    pub(super) fn consider(
        &self,
        id: u32,
        line: &ReachLine,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        best: &mut f64,
        lowest: &mut Option<u32>,
    ) {
        let Some(seg) = self.motions.get(id as usize) else {
            return;
        };
        if !self.may_reach(seg, line, p, n, *best) {
            return;
        }
        let h = self.sweep_min(seg, p, n, *best);
        if h < *best {
            *best = h;
            *lowest = Some(id);
        }
    }

    /// The fast residual with per-thread working memory.
    pub(super) fn residual_fast(
        &self,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        sc: &mut Scratch,
    ) -> Option<f64> {
        self.candidates_stamped(p, n, sc);
        let (r, lowest) = self.residual_of(p, n, &sc.ids);
        if lowest.is_some() {
            sc.last_best = lowest;
        }
        r
    }

    /// Residual over the candidate motions `ids`, and the motion giving it.
    pub(super) fn residual_of(
        &self,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        ids: &[u32],
    ) -> (Option<f64>, Option<u32>) {
        let line = ReachLine::new(p, n, self.depth, self.cap);
        let mut best = f64::INFINITY;
        let mut lowest = None;
        for &id in ids {
            self.consider(id, &line, p, n, &mut best, &mut lowest);
        }
        ((best <= self.cap).then_some(best), lowest)
    }

    /// Residuals of all samples (`nu` x `nv`, k = i nv + j), in parallel over
    /// tiles of TILE x TILE samples, a fixed number per task. The fast residual
    /// lists a tile's candidate motions once and carries the previous sample's
    /// lowest motion within a task, so tiles and tasks must not depend on the
    /// number of threads. A stop found by `check` is put in its cell and
    /// leaves the rest uncomputed.
    pub(super) fn residuals(
        &self,
        frames: &[Frame],
        (nu, nv): (usize, usize),
        method: Method,
        (progress, stop): (&dyn Progress, &std::sync::OnceLock<Error>),
    ) -> Vec<Option<f64>> {
        const TILE: usize = 8;
        const TILES_PER_TASK: usize = 16;
        let tiles: Vec<(usize, usize)> = (0..nu)
            .step_by(TILE)
            .flat_map(|i| (0..nv).step_by(TILE).map(move |j| (i, j)))
            .collect();
        let parts = toolpath_kernel::parallel::map_chunks(&tiles, TILES_PER_TASK, |tiles| {
            if stop.get().is_some() {
                return Vec::new();
            }
            if let Err(e) = progress.check() {
                let _ = stop.set(e);
                return Vec::new();
            }
            let mut scratch = Scratch::new(self.motions.len());
            let mut out = Vec::with_capacity(tiles.len() * TILE * TILE);
            for &(i0, j0) in tiles {
                let ks = (i0..(i0 + TILE).min(nu))
                    .flat_map(|i| (j0..(j0 + TILE).min(nv)).map(move |j| i * nv + j));
                let frame = |k: usize| frames.get(k).and_then(|f| f.as_ref());
                if method == Method::Fast {
                    self.tile_candidates(ks.clone().filter_map(frame), &mut scratch);
                }
                for k in ks {
                    let r = frame(k).and_then(|(p, n, _)| match method {
                        Method::Fast => self.residual_in_tile(p, n, &mut scratch),
                        #[cfg(feature = "reference")]
                        Method::Reference => self.residual_reference(p, n, &mut scratch.ids),
                    });
                    out.push((k, r));
                }
            }
            out
        });
        let mut residual = vec![None; frames.len()];
        for (k, r) in parts.into_iter().flatten() {
            if let Some(slot) = residual.get_mut(k) {
                *slot = r;
            }
        }
        residual
    }

    /// The residual by `method`, with per-thread working memory.
    pub(super) fn residual_by(
        &self,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        scratch: &mut Scratch,
        method: Method,
    ) -> Option<f64> {
        match method {
            Method::Fast => self.residual_fast(p, n, scratch),
            #[cfg(feature = "reference")]
            Method::Reference => self.residual_reference(p, n, &mut scratch.ids),
        }
    }
}
