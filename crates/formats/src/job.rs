//! Job files: what to machine, with which strategy, tool and parameters.

use super::shape::{shape_from_value, Shape};
use serde::{Deserialize, Serialize};
use std::path::Path;
use toolpath_kernel::error::{Error, Result};
use toolpath_kernel::tools::Tool;
use toolpath_kernel::validate::{finite, positive};

/// Planning strategies, named as in the job file format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Strategy {
    TensorRegions,
    IsoScallop,
    IsoParametric,
    Mpec,
    PocketMat,
    BeltIsoParametric,
    BeltIsoPlanar,
}

impl Strategy {
    pub const ALL: [Strategy; 7] = [
        Strategy::TensorRegions,
        Strategy::IsoScallop,
        Strategy::IsoParametric,
        Strategy::Mpec,
        Strategy::PocketMat,
        Strategy::BeltIsoParametric,
        Strategy::BeltIsoPlanar,
    ];
    pub fn name(self) -> &'static str {
        match self {
            Strategy::TensorRegions => "tensor_regions",
            Strategy::IsoScallop => "iso_scallop",
            Strategy::IsoParametric => "iso_parametric",
            Strategy::Mpec => "mpec",
            Strategy::PocketMat => "pocket_mat",
            Strategy::BeltIsoParametric => "belt_iso_parametric",
            Strategy::BeltIsoPlanar => "belt_iso_planar",
        }
    }
    pub fn parse(name: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|s| s.name() == name)
            .ok_or_else(|| {
                let names: Vec<_> = Self::ALL.iter().map(|s| s.name()).collect();
                Error::invalid(
                    "strategy",
                    format!(
                        "unknown strategy \"{name}\": expected one of {}",
                        names.join(", ")
                    ),
                )
            })
    }
    /// The method family the strategy belongs to.
    pub fn family(self) -> Family {
        match self {
            Strategy::TensorRegions | Strategy::IsoScallop | Strategy::IsoParametric => {
                Family::StripWidth
            }
            Strategy::Mpec => Family::Mpec,
            Strategy::PocketMat => Family::Pocket,
            Strategy::BeltIsoParametric | Strategy::BeltIsoPlanar => Family::Belt,
        }
    }
    /// The machine a strategy runs on by default ([`Family::default_machine`]).
    pub fn default_machine(self) -> Machine {
        self.family().default_machine()
    }
    /// Whether the strategy can plan with this tool ([`Family::accepts`]).
    pub fn accepts(self, tool: &Tool) -> bool {
        self.family().accepts(tool)
    }

    /// The tool kinds [`Strategy::accepts`], in words.
    pub(crate) fn tool_kinds(self) -> &'static str {
        self.family().tool_kinds()
    }

    /// Whether the strategy machines a pocket rather than a surface.
    pub fn needs_pocket(self) -> bool {
        self.family() == Family::Pocket
    }
}

/// The method families: the strategies of one family share a tool model,
/// a machine and the way their plans are verified.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Family {
    /// Flat-end (and ball) 5-axis finishing on the strip-width model
    /// (`tensor_regions`, `iso_scallop`, `iso_parametric`): checked by the
    /// scallop simulator, repaired with passes over its islands.
    StripWidth,
    /// Torus-cutter positioning by mid-point error control (`mpec`): checked
    /// by the scallop simulator against the band +-delta, refined with added
    /// passes.
    Mpec,
    /// 2.5-axis pockets (`pocket_mat`): the planner reports its own uncut
    /// area.
    Pocket,
    /// 6-axis belt grinding (`belt_iso_parametric`, `belt_iso_planar`):
    /// checked by the removal simulation, refined with re-stepped and added
    /// paths.
    Belt,
}

impl Family {
    /// Whether the family plans with this tool: the strip-width strategies
    /// take flat-end and ball cutters, mpec a torus, pocket_mat a flat end,
    /// the belt strategies a belt.
    pub fn accepts(self, tool: &Tool) -> bool {
        match self {
            Family::StripWidth => matches!(tool, Tool::FlatEnd { .. } | Tool::Ball { .. }),
            Family::Mpec => matches!(tool, Tool::Torus { .. }),
            Family::Pocket => matches!(tool, Tool::FlatEnd { .. }),
            Family::Belt => matches!(tool, Tool::Belt { .. }),
        }
    }

    /// The tool kinds [`Family::accepts`], in words.
    pub(crate) fn tool_kinds(self) -> &'static str {
        match self {
            Family::StripWidth => "flat-end and ball cutters",
            Family::Mpec => "torus cutters",
            Family::Pocket => "flat-end cutters",
            Family::Belt => "a belt",
        }
    }

    /// The machine the family's strategies run on by default.
    pub fn default_machine(self) -> Machine {
        match self {
            Family::Belt => Machine::Belt6,
            _ => Machine::Mill5,
        }
    }

    /// Whether the scallop simulator checks the family's plans (milling on
    /// a surface; pocket and belt results have checks of their own).
    pub fn scallop_simulated(self) -> bool {
        matches!(self, Family::StripWidth | Family::Mpec)
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Machine {
    Mill5,
    Belt6,
}

impl Machine {
    pub fn name(self) -> &'static str {
        match self {
            Machine::Mill5 => "mill5",
            Machine::Belt6 => "belt6",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FeedDirection {
    U,
    V,
}

/// Hamann linear material-removal model parameters (belt grinding):
/// r = C_A K_A k_t v_b F_A / (v_w L_w). Defaults documented in docs/formats.md.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GrindingParams {
    /// Process constant C_A.
    pub c_a: f64,
    /// Grit/belt wear constant K_A.
    pub k_a: f64,
    /// Time factor k_t.
    pub k_t: f64,
    /// Belt speed v_b, m/s.
    pub belt_speed: f64,
    /// Contact force F_A, N.
    pub force: f64,
    /// Workpiece (feed) speed v_w, mm/s.
    pub feed_speed: f64,
}

impl Default for GrindingParams {
    fn default() -> Self {
        // C_A = 0.002 makes Q = C_A K_A k_t v_b F_A / v_w = 0.04 mm^2: about
        // 0.02 mm removal depth on a flat part under a 25 mm wheel.
        Self {
            c_a: 0.002,
            k_a: 1.0,
            k_t: 1.0,
            belt_speed: 20.0,
            force: 20.0,
            feed_speed: 20.0,
        }
    }
}

/// The job as written in a file. Validated into [`Job`].
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JobFile {
    pub job_id: String,
    pub surface: serde_json::Value,
    pub strategy: Strategy,
    /// Required but for `pocket_mat`, which takes its tools from `tool_catalogue`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tool: Option<Tool>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub machine: Option<Machine>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scallop: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tolerance: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lead_angle_deg: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub side_tilt_deg: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub feed_direction: Option<FeedDirection>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub feed_rate: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tool_catalogue: Option<Vec<f64>>,
    /// Iso-planar: a fixed section-plane normal instead of the automatic one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub section_normal: Option<[f64; 3]>,
    /// Simulation grid spacing in mm (scallop and removal simulators).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub simulation_resolution: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grinding: Option<GrindingParams>,
    /// Stop planning after this many seconds (the job FAILS, stopped).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_limit_s: Option<f64>,
    /// The node sends the trajectory to the machine's controller (`true`) or
    /// only publishes it (`false`); absent: the machine's `controller.execute`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub execute: Option<bool>,
}

impl JobFile {
    /// A job file with only the required fields; every optional one absent
    /// (set them with struct update syntax).
    pub fn new(job_id: &str, strategy: Strategy, tool: Option<Tool>) -> Self {
        JobFile {
            job_id: job_id.to_string(),
            surface: serde_json::Value::Null,
            strategy,
            tool,
            machine: None,
            scallop: None,
            tolerance: None,
            lead_angle_deg: None,
            side_tilt_deg: None,
            feed_direction: None,
            feed_rate: None,
            tool_catalogue: None,
            section_normal: None,
            simulation_resolution: None,
            grinding: None,
            time_limit_s: None,
            execute: None,
        }
    }
}

/// A validated job.
#[derive(Clone, Debug, PartialEq)]
pub struct Job {
    pub job_id: String,
    pub shape: Shape,
    pub strategy: Strategy,
    /// `None` only for `pocket_mat` (its tools come from the catalogue).
    pub tool: Option<Tool>,
    pub machine: Machine,
    pub scallop: Option<f64>,
    pub tolerance: Option<f64>,
    pub lead_angle_deg: Option<f64>,
    pub side_tilt_deg: Option<f64>,
    pub feed_direction: Option<FeedDirection>,
    /// mm/min.
    pub feed_rate: f64,
    pub tool_catalogue: Vec<f64>,
    pub section_normal: Option<[f64; 3]>,
    pub simulation_resolution: Option<f64>,
    pub grinding: GrindingParams,
    /// s; `None`: only the limit of the CLI or node applies.
    pub time_limit_s: Option<f64>,
    /// Whether the node executes the trajectory; `None`: the machine's default.
    pub execute: Option<bool>,
}

/// Longest time limit a job (or a config) may give, s: a week. Beyond it a
/// limit is not one, and adding it to an instant stays far from overflow.
pub const MAX_TIME_LIMIT_S: f64 = 7.0 * 24.0 * 3600.0;

/// Default feed rate, mm/min.
pub const DEFAULT_FEED_RATE: f64 = 1000.0;

/// Depth below the surface a finishing cut may reach before it counts as a
/// gouge, mm, for jobs without a tolerance band: the limit the strip-width
/// planners are accepted with (tests/wing_mould.rs, tests/flat_end_suite.rs;
/// their plans' simulated gouges are in docs/results.md, "Flat-end strategy
/// suite").
pub(crate) const DEFAULT_GOUGE_TOLERANCE: f64 = 0.005;

/// Largest lead angle and side tilt, degrees: the tool axis within 45
/// degrees of the surface normal. Beyond it a flat end or torus cuts with
/// its side rather than its end, which the strip-width and MPEC models do
/// not describe: their widths and error curves would then miss the cut of
/// the cutter's side.
pub(crate) const MAX_TILT_DEG: f64 = 45.0;

/// Diameters a `tool_catalogue` may list, mm: from micro end mills to the
/// largest shank end mills.
pub(crate) const CATALOGUE_DIAMETERS_MM: std::ops::RangeInclusive<f64> = 0.1..=100.0;

/// Standard metric end-mill diameters, mm.
pub const DEFAULT_TOOL_CATALOGUE: [f64; 22] = [
    1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0, 14.0, 16.0, 18.0, 20.0, 25.0, 30.0,
    32.0, 35.0, 40.0, 45.0, 50.0,
];

impl JobFile {
    /// Checks every field that does not depend on the shape, with the reasons
    /// [`Job::new`] gives: a job message is refused before its shape arrives.
    pub fn validate(&self) -> Result<()> {
        self.checked_parameters()?;
        self.checked_tool_and_machine()?;
        Ok(())
    }

    /// The tool's sizes and the numbers; returns the tool catalogue (sorted,
    /// each diameter once).
    fn checked_parameters(&self) -> Result<Vec<f64>> {
        if let Some(tool) = &self.tool {
            tool.validate().map_err(|e| e.within("tool"))?;
        }
        self.scallop.map_or(Ok(()), |x| positive("scallop", x))?;
        self.tolerance
            .map_or(Ok(()), |x| positive("tolerance", x))?;
        self.feed_rate
            .map_or(Ok(()), |x| positive("feed_rate", x))?;
        self.simulation_resolution
            .map_or(Ok(()), |x| positive("simulation_resolution", x))?;
        self.time_limit_s
            .map_or(Ok(()), |x| positive("time_limit_s", x))?;
        if let Some(t) = self.time_limit_s {
            if t > MAX_TIME_LIMIT_S {
                return Err(Error::invalid(
                    "time_limit_s",
                    format!("{t} s is above the longest limit of {MAX_TIME_LIMIT_S} s (a week)"),
                ));
            }
        }
        self.lead_angle_deg
            .map_or(Ok(()), |x| finite("lead_angle_deg", x))?;
        self.side_tilt_deg
            .map_or(Ok(()), |x| finite("side_tilt_deg", x))?;
        for (name, angle) in [
            ("lead_angle_deg", self.lead_angle_deg),
            ("side_tilt_deg", self.side_tilt_deg),
        ] {
            if let Some(a) = angle {
                if a.abs() > MAX_TILT_DEG {
                    return Err(Error::invalid(
                        name,
                        format!(
                            "{a} is outside the valid range -{MAX_TILT_DEG}..{MAX_TILT_DEG} degrees"
                        ),
                    ));
                }
            }
        }
        if let Some(n) = self.section_normal {
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            if !len.is_finite() || len < 1e-12 {
                return Err(Error::invalid(
                    "section_normal",
                    "must be a finite non-zero vector",
                ));
            }
        }
        let catalogue = match &self.tool_catalogue {
            Some(c) => {
                if c.is_empty() {
                    return Err(Error::invalid(
                        "tool_catalogue",
                        "is empty: list at least one tool diameter",
                    ));
                }
                for (i, &d) in c.iter().enumerate() {
                    positive(&format!("tool_catalogue[{i}]"), d)?;
                    if !CATALOGUE_DIAMETERS_MM.contains(&d) {
                        return Err(Error::invalid(
                            format!("tool_catalogue[{i}]"),
                            format!(
                                "{d} mm is outside the valid range {}..{} mm of end-mill diameters",
                                CATALOGUE_DIAMETERS_MM.start(),
                                CATALOGUE_DIAMETERS_MM.end()
                            ),
                        ));
                    }
                }
                let mut c = c.clone();
                c.sort_by(f64::total_cmp);
                c.dedup();
                c
            }
            None => DEFAULT_TOOL_CATALOGUE.to_vec(),
        };
        if let Some(g) = &self.grinding {
            let fields = [
                ("c_a", g.c_a),
                ("k_a", g.k_a),
                ("k_t", g.k_t),
                ("belt_speed", g.belt_speed),
                ("force", g.force),
                ("feed_speed", g.feed_speed),
            ];
            for (name, v) in fields {
                positive(&format!("grinding.{name}"), v)?;
            }
        }
        Ok(catalogue)
    }

    /// The tool kind against the strategy and the machine against the tool;
    /// returns the machine (the strategy's default when not given).
    fn checked_tool_and_machine(&self) -> Result<Machine> {
        let machine = self.machine.unwrap_or(self.strategy.default_machine());
        let Some(tool) = &self.tool else {
            if !self.strategy.needs_pocket() {
                return Err(Error::invalid(
                    "tool",
                    format!(
                        "is missing: strategy {} needs one of its {}",
                        self.strategy.name(),
                        self.strategy.tool_kinds()
                    ),
                ));
            }
            if machine == Machine::Belt6 {
                return Err(Error::invalid(
                    "machine",
                    "machine belt6 cannot carry pocket_mat's milling tools",
                ));
            }
            return Ok(machine);
        };
        if !self.strategy.accepts(tool) {
            return Err(Error::invalid(
                "tool.kind",
                format!(
                    "strategy {} cannot use a {} tool (it plans {})",
                    self.strategy.name(),
                    tool.kind(),
                    self.strategy.tool_kinds()
                ),
            ));
        }
        if (machine == Machine::Belt6) != matches!(tool, Tool::Belt { .. }) {
            return Err(Error::invalid(
                "machine",
                format!(
                    "machine {} cannot carry a {} tool",
                    machine.name(),
                    tool.kind()
                ),
            ));
        }
        Ok(machine)
    }
}

/// A pocket for `pocket_mat`, a NURBS surface for every other strategy.
fn check_shape_kind(strategy: Strategy, shape: &Shape) -> Result<()> {
    match (shape, strategy.needs_pocket()) {
        (Shape::Pocket(_), false) => Err(Error::invalid(
            "surface",
            format!(
                "strategy {} needs a NURBS surface, got a pocket",
                strategy.name()
            ),
        )),
        (Shape::Surface(_), true) => Err(Error::invalid(
            "surface",
            "strategy pocket_mat needs a pocket, got a NURBS surface",
        )),
        (Shape::Surface(s), false) => check_smooth(s),
        _ => Ok(()),
    }
}

/// Largest angle between the normals on the two sides of a knot that still
/// counts as smooth, radians: a tangent-continuous join (an exact circle
/// built from arcs with double knots) differs only by rounding there.
const CREASE_ANGLE: f64 = 1e-3;

/// Refuses a surface with a crease: an interior knot of multiplicity at
/// least the degree lets the surface be only C0 there, and where the normal
/// really jumps across it the planners' curvature model, which assumes a
/// smooth surface, would gouge. Such knots are checked geometrically (normals
/// on both sides at nine points along the knot line), so a tangent-continuous
/// join such as a rational circle with double knots is accepted. Each smooth
/// piece of a creased surface can be planned on its own.
fn check_smooth(s: &toolpath_kernel::geometry::NurbsSurface) -> Result<()> {
    for (name, knots, degree) in [
        ("knots_u", s.knots_u(), s.degree_u()),
        ("knots_v", s.knots_v(), s.degree_v()),
    ] {
        let (first, last) = (knots[0], knots[knots.len() - 1]);
        let mut k = 0;
        while k < knots.len() {
            let run = knots[k..].iter().take_while(|&&x| x == knots[k]).count();
            if knots[k] > first && knots[k] < last && run >= degree {
                if let Some(angle) = normal_jump(s, name == "knots_u", knots[k], last - first) {
                    return Err(Error::invalid(
                        format!("surface.{name}[{k}]"),
                        format!(
                            "knot {} has multiplicity {run}, not below the degree {degree}, and the normal turns by {:.2} deg across it: the surface has a crease (only C0) there; split it at the crease and plan each smooth piece as its own job",
                            knots[k],
                            angle.to_degrees()
                        ),
                    ));
                }
            }
            k += run;
        }
    }
    Ok(())
}

/// The largest angle between the normals just before and just after the
/// knot `t` (of u when `along_u`, else of v) at nine points along the knot
/// line, when it exceeds [`CREASE_ANGLE`].
fn normal_jump(
    s: &toolpath_kernel::geometry::NurbsSurface,
    along_u: bool,
    t: f64,
    span: f64,
) -> Option<f64> {
    let ((u0, u1), (v0, v1)) = s.domain();
    let dt = 1e-7 * span;
    let mut worst: f64 = 0.0;
    for i in 0..9 {
        let c = i as f64 / 8.0;
        let (before, after) = if along_u {
            let v = v0 + (v1 - v0) * c;
            (s.normal(t - dt, v), s.normal(t + dt, v))
        } else {
            let u = u0 + (u1 - u0) * c;
            (s.normal(u, t - dt), s.normal(u, t + dt))
        };
        // A normal undefined at a point (a pole) says nothing of a crease.
        if let (Some(a), Some(b)) = (before, after) {
            worst = worst.max(a.dot(&b).clamp(-1.0, 1.0).acos());
        }
    }
    (worst > CREASE_ANGLE).then_some(worst)
}

/// The face `face` (its STEP entity id) of the STEP file at `path`, as
/// `toolpath import --face` writes it (docs/formats.md, "STEP import").
/// A STEP face id given at `field`: a whole number.
fn face_id(field: String, face: &serde_json::Value) -> Result<u64> {
    face.as_u64().ok_or_else(|| {
        Error::invalid(
            field,
            format!("must be a STEP entity id (a whole number, as `toolpath import --list` shows), not {face}"),
        )
    })
}

/// Face `id` of a read STEP file as a job's shape.
fn face_shape(step: &super::step::StepFile, id: u64) -> Result<Shape> {
    let surface = step
        .face(id)
        .map_err(|e| super::step::within_field(e, "surface"))?;
    let value =
        serde_json::to_value(surface).map_err(|e| Error::invalid("surface.face", e.to_string()))?;
    shape_from_value(value).map_err(|e| e.within("surface"))
}

/// The file a `{"file": path, ...}` surface names, relative paths from `base_dir`.
fn surface_file(
    map: &serde_json::Map<String, serde_json::Value>,
    base_dir: Option<&Path>,
) -> Result<std::path::PathBuf> {
    let file = match map.get("file") {
        Some(serde_json::Value::String(s)) => s.clone(),
        _ => return Err(Error::invalid("surface.file", "must be a string path")),
    };
    Ok(match base_dir {
        Some(d) if Path::new(&file).is_relative() => d.join(&file),
        _ => Path::new(&file).to_path_buf(),
    })
}

fn read_step(path: &Path) -> Result<super::step::StepFile> {
    super::step::StepFile::read(path).map_err(|e| super::step::within_field(e, "surface"))
}

/// The STEP face ids of a job whose surface is `{"file": STEP path,
/// "faces": [ID, ...]}`, checked: a non-empty list of distinct whole
/// numbers. `None` for every other surface.
fn face_list(surface: &serde_json::Value) -> Result<Option<Vec<u64>>> {
    let Some(faces) = surface.as_object().and_then(|m| m.get("faces")) else {
        return Ok(None);
    };
    if surface.get("face").is_some() {
        return Err(Error::invalid(
            "surface",
            "give either \"face\" or \"faces\", not both",
        ));
    }
    let list = faces.as_array().ok_or_else(|| {
        Error::invalid(
            "surface.faces",
            format!("must be a list of STEP face ids, not {faces}"),
        )
    })?;
    if list.is_empty() {
        return Err(Error::invalid(
            "surface.faces",
            "is empty: name at least one face",
        ));
    }
    let mut ids = Vec::with_capacity(list.len());
    for (k, v) in list.iter().enumerate() {
        let id = face_id(format!("surface.faces[{k}]"), v)?;
        if let Some(first) = ids.iter().position(|&x| x == id) {
            return Err(Error::invalid(
                format!("surface.faces[{k}]"),
                format!("repeats face #{id} (already surface.faces[{first}])"),
            ));
        }
        ids.push(id);
    }
    Ok(Some(ids))
}

/// The jobs of a job file: one per face, in the order given, when its
/// surface names several STEP faces (`{"file": STEP path, "faces": [ID,
/// ...]}`, docs/formats.md, "Several faces"), else the one job. Every face's
/// job has the file's parameters and job id.
pub(crate) fn jobs_from_file(f: JobFile, base_dir: Option<&Path>) -> Result<Vec<Job>> {
    let Some(ids) = face_list(&f.surface)? else {
        return Job::from_file(f, base_dir).map(|j| vec![j]);
    };
    if f.job_id.trim().is_empty() {
        return Err(Error::invalid("job_id", "must not be empty"));
    }
    let map = f.surface.as_object().cloned().unwrap_or_default();
    // One read of the file serves every face.
    let step = read_step(&surface_file(&map, base_dir)?)?;
    ids.iter()
        .map(|&id| {
            let one = JobFile {
                surface: serde_json::json!({"file": map.get("file"), "face": id}),
                ..f.clone()
            };
            Job::new(one, face_shape(&step, id)?)
        })
        .collect()
}

impl Job {
    /// Validates a parsed job file. `base_dir` resolves `{"file": ...}` surfaces.
    pub fn from_file(f: JobFile, base_dir: Option<&Path>) -> Result<Self> {
        if f.job_id.trim().is_empty() {
            return Err(Error::invalid("job_id", "must not be empty"));
        }
        let shape = match &f.surface {
            serde_json::Value::Object(map) if map.contains_key("file") => {
                let path = surface_file(map, base_dir)?;
                if map.contains_key("faces") {
                    return Err(Error::invalid(
                        "surface.faces",
                        "a job on several faces is planned face by face (`toolpath plan`, formats::read_jobs); here give one \"face\"",
                    ));
                }
                match map.get("face") {
                    None => super::read_shape(&path).map_err(|e| e.within("surface"))?,
                    Some(face) => {
                        let id = face_id("surface.face".into(), face)?;
                        face_shape(&read_step(&path)?, id)?
                    }
                }
            }
            serde_json::Value::Object(_) => {
                shape_from_value(f.surface.clone()).map_err(|e| e.within("surface"))?
            }
            _ => {
                return Err(Error::invalid(
                    "surface",
                    "must be a surface or pocket object, {\"file\": path}, or {\"file\": STEP path, \"face\": id}",
                ))
            }
        };
        Self::new(f, shape)
    }

    /// Validates the parameters of `f` against an already-built shape.
    pub fn new(f: JobFile, shape: Shape) -> Result<Self> {
        let catalogue = f.checked_parameters()?;
        check_shape_kind(f.strategy, &shape)?;
        let machine = f.checked_tool_and_machine()?;
        Ok(Self {
            job_id: f.job_id,
            shape,
            strategy: f.strategy,
            tool: f.tool,
            machine,
            scallop: f.scallop,
            tolerance: f.tolerance,
            lead_angle_deg: f.lead_angle_deg,
            side_tilt_deg: f.side_tilt_deg,
            feed_direction: f.feed_direction,
            feed_rate: f.feed_rate.unwrap_or(DEFAULT_FEED_RATE),
            tool_catalogue: catalogue,
            section_normal: f.section_normal,
            simulation_resolution: f.simulation_resolution,
            grinding: f.grinding.unwrap_or_default(),
            time_limit_s: f.time_limit_s,
            execute: f.execute,
        })
    }

    /// Back to the file form, with the shape embedded.
    pub fn to_file(&self) -> JobFile {
        JobFile {
            job_id: self.job_id.clone(),
            surface: self.shape.to_json(),
            strategy: self.strategy,
            tool: self.tool,
            machine: Some(self.machine),
            scallop: self.scallop,
            tolerance: self.tolerance,
            lead_angle_deg: self.lead_angle_deg,
            side_tilt_deg: self.side_tilt_deg,
            feed_direction: self.feed_direction,
            feed_rate: Some(self.feed_rate),
            tool_catalogue: (self.tool_catalogue != DEFAULT_TOOL_CATALOGUE)
                .then(|| self.tool_catalogue.clone()),
            section_normal: self.section_normal,
            simulation_resolution: self.simulation_resolution,
            grinding: (self.grinding != GrindingParams::default()).then_some(self.grinding),
            time_limit_s: self.time_limit_s,
            execute: self.execute,
        }
    }

    pub fn surface(&self) -> Result<&toolpath_kernel::geometry::NurbsSurface> {
        self.shape.as_surface().ok_or_else(|| {
            Error::invalid(
                "surface",
                format!("strategy {} needs a NURBS surface", self.strategy.name()),
            )
        })
    }
    pub fn pocket(&self) -> Result<&toolpath_kernel::geometry::Pocket> {
        self.shape.as_pocket().ok_or_else(|| {
            Error::invalid(
                "surface",
                format!("strategy {} needs a pocket", self.strategy.name()),
            )
        })
    }
    /// Required scallop height, with an error naming the strategy when absent.
    pub fn scallop(&self) -> Result<f64> {
        self.scallop.ok_or_else(|| {
            Error::invalid(
                "scallop",
                format!("required by strategy {}", self.strategy.name()),
            )
        })
    }
    pub fn tolerance(&self) -> Result<f64> {
        self.tolerance.ok_or_else(|| {
            Error::invalid(
                "tolerance",
                format!("required by strategy {}", self.strategy.name()),
            )
        })
    }

    /// How deep a cut may go below the surface before it is a gouge, mm:
    /// MPEC's band (`tolerance`, its +-delta), else [`DEFAULT_GOUGE_TOLERANCE`].
    pub fn gouge_tolerance(&self) -> f64 {
        match (self.strategy.family(), self.tolerance) {
            (Family::Mpec, Some(delta)) => delta,
            _ => DEFAULT_GOUGE_TOLERANCE,
        }
    }
    /// Lead angle in radians (default 0 when absent).
    /// The job's tool; an error for a job without one (a pocket job, whose
    /// tools come from the catalogue).
    pub fn tool(&self) -> Result<&Tool> {
        self.tool.as_ref().ok_or_else(|| {
            Error::invalid(
                "tool",
                format!(
                    "is missing: strategy {} needs a tool here",
                    self.strategy.name()
                ),
            )
        })
    }

    /// Flute length for the machine's kinematics: the tool's, or for a job
    /// without a tool the default length of the largest catalogue tool.
    pub fn tool_length(&self) -> f64 {
        match &self.tool {
            Some(tool) => tool.length(),
            None => {
                let d = self.tool_catalogue.iter().copied().fold(0.0, f64::max);
                Tool::FlatEnd {
                    radius: 0.5 * d,
                    length: None,
                }
                .length()
            }
        }
    }

    pub fn lead_angle(&self) -> f64 {
        self.lead_angle_deg.unwrap_or(0.0).to_radians()
    }
    pub fn side_tilt(&self) -> f64 {
        self.side_tilt_deg.unwrap_or(0.0).to_radians()
    }
}
