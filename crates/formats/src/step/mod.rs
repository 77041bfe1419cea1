//! STEP import (docs/formats.md, "STEP import"): the faces of a Part 21 file
//! (AP203/AP214/AP242) as trimmed NURBS surfaces in mm.
//!
//! ruststep parses the exchange structure into its generic records; the
//! mapping of the few entities a face needs onto our shapes is written here:
//! `ADVANCED_FACE` (or `FACE_SURFACE`) on `B_SPLINE_SURFACE_WITH_KNOTS`
//! (rational or not), `PLANE`, or a surface of revolution (`CYLINDRICAL_`,
//! `CONICAL_`, `SPHERICAL_`, `TOROIDAL_SURFACE`, `SURFACE_OF_REVOLUTION`),
//! or `SURFACE_OF_LINEAR_EXTRUSION`, all converted to exact NURBS, bounded by `EDGE_LOOP`s of `EDGE_CURVE`s on `LINE`,
//! `CIRCLE`, `ELLIPSE` and B-spline curves. On a B-spline surface an edge
//! uses its pcurve on that surface when the file gives one; every other edge
//! (and every edge of a plane, revolved or extruded surface, whose own parametrisation differs
//! from the NURBS written) is its 3-D curve projected onto the surface. Each
//! loop is written as one closed polyline in (u, v), sampled so that the
//! surface image of every chord stays within the trim tolerance of the edge.
//! Lengths are converted to mm from the file's length unit. The face's
//! orientation is honoured: a face whose `same_sense` is false gets its u
//! direction reversed, so the surface normal is the face's.
//!
//! | module | what |
//! | --- | --- |
//! | `records` | the parsed file: entity records, typed parameters, points and placements |
//! | `units` | the length and plane angle units |
//! | `curves` | edge curves (line, conic, B-spline) and their evaluation |
//! | `surfaces` | the surface a face lies on, as read ([`surfaces::Basis`]) |
//! | `bspline` | B-spline curves and surfaces in every form STEP writes |
//! | `offset` | offset surfaces: exact for elementary bases, else fitted within [`OFFSET_FIT_TOLERANCE_MM`] |
//! | `patches` | that surface as a NURBS patch over the face, with the map of its boundary to (u, v) |
//! | `loops` | the face's bounds as closed (u, v) polylines |

mod bspline;
mod curves;
mod loops;
mod offset;
mod patches;
mod records;
mod surfaces;
mod units;

pub use curves::SUPPORTED_CURVES;
pub use offset::OFFSET_FIT_TOLERANCE_MM;

use super::shape::{SurfaceFile, TrimCurveFile, TrimFile};
use loops::{Bound, SampledLoop};
use nalgebra::{Point3, Vector3};
use ruststep::ast::Record;
use std::collections::BTreeMap;
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::geometry::NurbsSurface;

/// Largest STEP file read, bytes.
pub const MAX_STEP_BYTES: u64 = 512 << 20;

/// Surface types a face may lie on.
pub const SUPPORTED_SURFACES: &str = "B_SPLINE_SURFACE_WITH_KNOTS, BEZIER_SURFACE, UNIFORM_SURFACE, QUASI_UNIFORM_SURFACE (rational too), PLANE, CYLINDRICAL_SURFACE, CONICAL_SURFACE, SPHERICAL_SURFACE, TOROIDAL_SURFACE, SURFACE_OF_REVOLUTION, SURFACE_OF_LINEAR_EXTRUSION, OFFSET_SURFACE, RECTANGULAR_TRIMMED_SURFACE";

/// Grid cells per direction of the area integration of `--list`.
pub const LIST_CELLS: usize = 128;

type V3 = Vector3<f64>;

/// One face of a STEP file, as `toolpath import --list` shows it.
#[derive(Clone, Debug)]
pub struct FaceSummary {
    pub id: u64,
    /// The surface entity's type, e.g. `B_SPLINE_SURFACE_WITH_KNOTS`.
    pub surface_type: String,
    /// The trimmed face's area and bounding box, or why the face cannot be
    /// imported.
    pub imported: std::result::Result<FaceExtent, String>,
}

/// Area and bounding box of an imported face.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceExtent {
    /// Area of the trimmed face, mm².
    pub area_mm2: f64,
    /// Bounding box corners, mm.
    pub lo: [f64; 3],
    pub hi: [f64; 3],
}

/// A parsed STEP file: its entity instances by id and its length unit.
pub struct StepFile {
    label: String,
    stem: String,
    entities: BTreeMap<u64, Vec<Record>>,
    mm_per_unit: f64,
    radians_per_unit: f64,
}

/// A part's faces as one job needs them ([`StepFile::part_faces`]).
#[derive(Clone, Debug)]
pub struct PartFaces {
    /// The faces the job machines, in the order asked for.
    pub machined: Vec<PartFace>,
    /// The other faces of the same shells (the whole file's where the
    /// machined faces are in no shell), ascending by id: the check faces.
    pub others: Vec<PartFace>,
    /// Those of the other faces that cannot be read, with the reason.
    pub unreadable: Vec<UnreadableFace>,
}

/// One imported face and its STEP entity id.
#[derive(Clone, Debug)]
pub struct PartFace {
    pub id: u64,
    pub surface: SurfaceFile,
}

/// A face that cannot be imported: its entity id and the reason.
#[derive(Clone, Debug, PartialEq)]
pub struct UnreadableFace {
    pub id: u64,
    pub reason: String,
}

/// `e`, an error of this file's entities, as the error of a job's field
/// `parent`: `parent (mould.step #788 PLANE): message`.
pub fn within_field(e: Error, parent: &str) -> Error {
    match e {
        Error::Invalid { field, message } => Error::Invalid {
            field: format!("{parent} ({field})"),
            message,
        },
        other => other,
    }
}

impl StepFile {
    /// Ids of the faces (`ADVANCED_FACE`, `FACE_SURFACE`), ascending.
    pub fn face_ids(&self) -> Vec<u64> {
        self.entities
            .iter()
            .filter(|(_, r)| {
                r.len() == 1 && (r[0].name == "ADVANCED_FACE" || r[0].name == "FACE_SURFACE")
            })
            .map(|(&id, _)| id)
            .collect()
    }

    /// Every face with its surface type, area and bounding box.
    pub fn summaries(&self) -> Vec<FaceSummary> {
        self.face_ids()
            .into_iter()
            .map(|id| {
                let surface_type = self
                    .face_surface(id)
                    .map(|s| self.surface_type(s))
                    .unwrap_or_else(|_| "?".into());
                let imported = self
                    .face(id)
                    .and_then(|f| {
                        let s = f.to_surface()?;
                        let area = s.trim().map(|t| t.face_area(&s, LIST_CELLS)).unwrap_or(0.0);
                        let (lo, hi) = face_box(&s);
                        Ok(FaceExtent {
                            area_mm2: area,
                            lo,
                            hi,
                        })
                    })
                    .map_err(|e| e.to_string());
                FaceSummary {
                    id,
                    surface_type,
                    imported,
                }
            })
            .collect()
    }

    /// The surface's entity type; a complex B-spline surface is named by
    /// its most specific part.
    fn surface_type(&self, id: u64) -> String {
        if self.part(id, "RATIONAL_B_SPLINE_SURFACE").is_some() {
            return "RATIONAL_B_SPLINE_SURFACE".into();
        }
        self.kind(id).unwrap_or_else(|_| "?".into())
    }

    fn face_surface(&self, id: u64) -> Result<u64> {
        let (_, p) = self.expect(id, &["ADVANCED_FACE", "FACE_SURFACE"])?;
        self.reference(id, p, 2)
    }

    /// Face `id` as a trimmed surface in mm (named `STEM_ID`).
    pub fn face(&self, id: u64) -> Result<SurfaceFile> {
        if !self.entities.contains_key(&id) {
            return Err(Error::invalid(
                &self.label,
                format!("has no entity #{id} (faces: {})", self.face_list()),
            ));
        }
        let (_, p) = match self.expect(id, &["ADVANCED_FACE", "FACE_SURFACE"]) {
            Ok(x) => x,
            Err(_) => {
                return Err(self.err(id, format!("is not a face (faces: {})", self.face_list())))
            }
        };
        let bounds = self.references(id, p, 1)?;
        let surface_id = self.reference(id, p, 2)?;
        let same_sense = self.boolean(id, p, 3)?;
        let basis = self.basis(surface_id)?;
        let mut loops = Vec::new();
        for b in &bounds {
            let (kind, bp) = self.expect(*b, &["FACE_OUTER_BOUND", "FACE_BOUND"])?;
            let loop_id = self.reference(*b, bp, 1)?;
            let orientation = self.boolean(*b, bp, 2)?;
            let edges = self.edge_loop(loop_id, surface_id, &basis)?;
            loops.push(Bound {
                id: *b,
                declared_outer: kind == "FACE_OUTER_BOUND",
                orientation,
                edges,
            });
        }
        if loops.is_empty() {
            return Err(self.err(id, "has no bounds"));
        }
        let (mut surface, mut polylines) = self.sample_loops(id, basis, &loops)?;
        if !same_sense {
            let (u0, u1) = (surface.knots_u[0], *surface.knots_u.last().unwrap_or(&1.0));
            surface.control_points.reverse();
            if let Some(w) = &mut surface.weights {
                w.reverse();
            }
            surface.knots_u = surface.knots_u.iter().rev().map(|k| u0 + u1 - k).collect();
            for l in &mut polylines {
                for q in l.points.iter_mut() {
                    q[0] = u0 + u1 - q[0];
                }
            }
        }
        let outer = self.outer_index(id, &polylines)?;
        let mut holes = Vec::new();
        let mut outer_loop = Vec::new();
        for (k, l) in polylines.into_iter().enumerate() {
            let SampledLoop { points, .. } = l;
            if k == outer {
                outer_loop = vec![TrimCurveFile::Polyline(points)];
            } else {
                holes.push(vec![TrimCurveFile::Polyline(points)]);
            }
        }
        surface.name = Some(format!("{}_{id}", self.stem));
        surface.trim = Some(TrimFile {
            tolerance: None,
            outer: outer_loop,
            holes,
        });
        surface
            .to_surface()
            .map_err(|e| self.err(id, format!("gives an invalid trimmed surface: {e}")))?;
        Ok(surface)
    }

    /// The faces `machined` (an error names the first that cannot be
    /// read, its entity and why) and every other face of their shells
    /// (`CLOSED_SHELL`, `OPEN_SHELL`), of which those that cannot be read
    /// are listed, not an error: a job plans what it machines whatever the
    /// rest of the part holds.
    pub fn part_faces(&self, machined: &[u64]) -> Result<PartFaces> {
        let machined_faces = machined
            .iter()
            .map(|&id| {
                Ok(PartFace {
                    id,
                    surface: self.face(id)?,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        let mut others = Vec::new();
        let mut unreadable = Vec::new();
        for id in self.shell_faces(machined) {
            if machined.contains(&id) {
                continue;
            }
            match self.face(id) {
                Ok(surface) => others.push(PartFace { id, surface }),
                Err(e) => unreadable.push(UnreadableFace {
                    id,
                    reason: e.to_string(),
                }),
            }
        }
        Ok(PartFaces {
            machined: machined_faces,
            others,
            unreadable,
        })
    }

    /// The faces of every shell holding one of `faces`, ascending; every
    /// face of the file when none does.
    fn shell_faces(&self, faces: &[u64]) -> Vec<u64> {
        let mut out = std::collections::BTreeSet::new();
        for (&id, records) in &self.entities {
            let is_shell = records.len() == 1
                && matches!(records[0].name.as_str(), "CLOSED_SHELL" | "OPEN_SHELL");
            if !is_shell {
                continue;
            }
            let Some(p) = records::list(&records[0].parameter) else {
                continue;
            };
            let Ok(listed) = self.references(id, p, 1) else {
                continue;
            };
            if listed.iter().any(|f| faces.contains(f)) {
                out.extend(listed);
            }
        }
        if out.is_empty() {
            return self.face_ids();
        }
        let all: std::collections::BTreeSet<u64> = self.face_ids().into_iter().collect();
        out.into_iter().filter(|f| all.contains(f)).collect()
    }

    fn face_list(&self) -> String {
        let ids: Vec<String> = self.face_ids().iter().map(|i| format!("#{i}")).collect();
        if ids.is_empty() {
            "none".into()
        } else {
            ids.join(", ")
        }
    }
}

/// Bounding box of a trimmed face: its loops' points and the face's points
/// of a 64 x 64 grid of the domain.
fn face_box(s: &NurbsSurface) -> ([f64; 3], [f64; 3]) {
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    let mut add = |p: Point3<f64>| {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    };
    if let Some(t) = s.trim() {
        for l in t.loops() {
            for q in l {
                add(s.point(q[0], q[1]));
            }
        }
    }
    let ((u0, u1), (v0, v1)) = s.domain();
    let n = 64;
    for i in 0..=n {
        for j in 0..=n {
            let u = u0 + (u1 - u0) * i as f64 / n as f64;
            let v = v0 + (v1 - v0) * j as f64 / n as f64;
            if s.in_face(u, v) {
                add(s.point(u, v));
            }
        }
    }
    (lo, hi)
}
