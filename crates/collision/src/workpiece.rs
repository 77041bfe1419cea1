//! The part as the collision check sees it: its faces, their samples with
//! cover radii, the bounding-sphere hierarchy over them, and which faces the
//! current job machines (every other face is a check face).

use crate::bvh::Bvh;
use crate::error::{Error, Result};
use crate::face::Face;
use crate::parallel::map_indexed;
use crate::sampling::{sample_root_cell, Sample, SamplingOptions};
use std::sync::Arc;

/// A part of trimmed faces, sampled and indexed for pose queries.
#[derive(Clone)]
pub struct Workpiece {
    pub(crate) faces: Vec<Arc<dyn Face>>,
    pub(crate) samples: Vec<Sample>,
    pub(crate) bvh: Bvh,
    pub(crate) machined: Vec<bool>,
    /// Per node: does it hold a sample of a check face?
    pub(crate) node_check: Vec<bool>,
    options: SamplingOptions,
    samples_per_face: Vec<usize>,
}

impl std::fmt::Debug for Workpiece {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Workpiece")
            .field("faces", &self.faces.len())
            .field("samples", &self.samples.len())
            .field("machined", &self.machined)
            .finish()
    }
}

impl Workpiece {
    /// Samples every face (all of them check faces until
    /// [`Self::set_machined`]). Errors name `options.*` or `faces[i]`: a
    /// domain that is not a rectangle of finite, increasing bounds, a face
    /// that evaluates to a non-finite point, or one that needs more than
    /// `max_samples_per_face` samples.
    pub fn new(faces: Vec<Arc<dyn Face>>, options: SamplingOptions) -> Result<Self> {
        options.validate().map_err(|e| e.within("options"))?;
        if faces.len() > u32::MAX as usize {
            return Err(Error::invalid("faces", "too many faces"));
        }
        for (i, f) in faces.iter().enumerate() {
            let ([u0, u1], [v0, v1]) = f.domain();
            let ok = [u0, u1, v0, v1].iter().all(|x| x.is_finite()) && u0 < u1 && v0 < v1;
            if !ok {
                return Err(Error::invalid(
                    format!("faces[{i}].domain"),
                    format!(
                        "([{u0}, {u1}], [{v0}, {v1}]) is not a rectangle with u0 < u1, v0 < v1"
                    ),
                ));
            }
        }
        let n = options.root_cells;
        let per_face = n * n;
        let tasks = faces.len() * per_face;
        let results = map_indexed(tasks, options.threads, |t| {
            let (fi, cell) = (t / per_face, t % per_face);
            let mut out = Vec::new();
            sample_root_cell(
                faces[fi].as_ref(),
                fi as u32,
                (cell / n, cell % n),
                &options,
                &mut out,
            )
            .map(|()| out)
        });
        let mut samples = Vec::new();
        let mut samples_per_face = vec![0usize; faces.len()];
        for (t, r) in results.into_iter().enumerate() {
            let chunk = r?;
            samples_per_face[t / per_face] += chunk.len();
            samples.extend(chunk);
        }
        for (i, &count) in samples_per_face.iter().enumerate() {
            if count > options.max_samples_per_face {
                return Err(Error::invalid(
                    format!("faces[{i}]"),
                    format!(
                        "needs {count} samples at a spacing of {} mm, more than the limit {}",
                        options.spacing, options.max_samples_per_face
                    ),
                ));
            }
        }
        let bvh = Bvh::build(&mut samples);
        let mut w = Self {
            machined: vec![false; faces.len()],
            node_check: Vec::new(),
            faces,
            samples,
            bvh,
            options,
            samples_per_face,
        };
        w.update_node_check();
        Ok(w)
    }

    /// The faces the job machines (by index); every other face is a check
    /// face. The cutter may touch machined faces; nothing else may.
    pub fn set_machined(&mut self, machined: &[usize]) -> Result<()> {
        let mut flags = vec![false; self.faces.len()];
        for (k, &i) in machined.iter().enumerate() {
            if i >= self.faces.len() {
                return Err(Error::invalid(
                    format!("machined[{k}]"),
                    format!(
                        "face {i} does not exist (the part has {} faces)",
                        self.faces.len()
                    ),
                ));
            }
            flags[i] = true;
        }
        self.machined = flags;
        self.update_node_check();
        Ok(())
    }

    fn update_node_check(&mut self) {
        let nodes = &self.bvh.nodes;
        let mut check = vec![false; nodes.len()];
        // Children always come after their parent, so a reverse pass sees
        // them first.
        for (i, node) in nodes.iter().enumerate().rev() {
            check[i] = if node.is_leaf() {
                let range = node.first as usize..(node.first + node.count) as usize;
                self.samples[range]
                    .iter()
                    .any(|s| !self.machined[s.face as usize])
            } else {
                check[node.first as usize] || check[node.first as usize + 1]
            };
        }
        self.node_check = check;
    }

    pub fn face_count(&self) -> usize {
        self.faces.len()
    }

    pub fn face(&self, i: usize) -> &dyn Face {
        self.faces[i].as_ref()
    }

    /// Is face `i` machined by the current job?
    pub fn is_machined(&self, i: usize) -> bool {
        self.machined[i]
    }

    /// The samples, in the hierarchy's leaf order.
    pub fn samples(&self) -> &[Sample] {
        &self.samples
    }

    /// Number of samples of each face.
    pub fn samples_per_face(&self) -> &[usize] {
        &self.samples_per_face
    }

    pub fn options(&self) -> &SamplingOptions {
        &self.options
    }

    /// Largest cover radius of any sample: how far the certified bounds can
    /// lie below the exact distance.
    pub fn max_cover(&self) -> f64 {
        self.samples.iter().map(|s| s.cover).fold(0.0, f64::max)
    }
}
