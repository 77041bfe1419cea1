//! Bad input gets an error naming the field, never a panic.

use nalgebra::Vector3;
use std::sync::Arc;
use toolpath_collision::shapes::{horizontal_rectangle, Wave};
use toolpath_collision::{
    check_motion, Face, FaceDerivs, Motion, Pose, QueryOptions, SamplingOptions, SweepOptions,
    ToolAssembly, Workpiece,
};

/// A face that goes to infinity inside its domain.
struct Blows;

impl Face for Blows {
    fn domain(&self) -> ([f64; 2], [f64; 2]) {
        ([0.0, 1.0], [0.0, 1.0])
    }
    fn point(&self, u: f64, v: f64) -> Vector3<f64> {
        self.derivatives(u, v).p
    }
    fn derivatives(&self, u: f64, v: f64) -> FaceDerivs {
        let z = if u > 0.6 { f64::NAN } else { 0.0 };
        FaceDerivs {
            p: Vector3::new(u, v, z),
            su: Vector3::x(),
            sv: Vector3::y(),
            suu: Vector3::zeros(),
            suv: Vector3::zeros(),
            svv: Vector3::zeros(),
        }
    }
}

#[test]
fn faces_and_options_name_what_is_wrong() {
    let opts = SamplingOptions::for_cutter_radius(5.0);
    let good: Arc<dyn Face> = Arc::new(horizontal_rectangle(0.0, [0.0, 10.0], [0.0, 10.0]));
    let e = Workpiece::new(vec![good.clone(), Arc::new(Blows)], opts).unwrap_err();
    assert_eq!(e.field, "faces[1]");
    assert!(e.message.contains("not finite"), "{e}");
    let flat: Arc<dyn Face> = Arc::new(horizontal_rectangle(0.0, [1.0, 1.0], [0.0, 10.0]));
    let e = Workpiece::new(vec![flat], opts).unwrap_err();
    assert_eq!(e.field, "faces[0].domain");
    let e = Workpiece::new(
        vec![good.clone()],
        SamplingOptions {
            spacing: -1.0,
            ..opts
        },
    )
    .unwrap_err();
    assert_eq!(e.field, "options.spacing");
    // A spacing far too fine for a large face.
    let wave: Arc<dyn Face> = Arc::new(Wave {
        base: 0.0,
        amplitude: 1.0,
        wavelength: 5.0,
        u: [0.0, 100.0],
        v: [0.0, 100.0],
    });
    let tiny = SamplingOptions {
        spacing: 0.01,
        max_samples_per_face: 10_000,
        ..opts
    };
    let e = Workpiece::new(vec![wave], tiny).unwrap_err();
    assert_eq!(e.field, "faces[0]");
    assert!(e.message.contains("samples"), "{e}");
    let mut w = Workpiece::new(vec![good], opts).unwrap();
    let e = w.set_machined(&[0, 3]).unwrap_err();
    assert_eq!(e.field, "machined[1]");
}

#[test]
fn queries_refuse_bad_limits_and_motions() {
    let w = Workpiece::new(
        vec![Arc::new(horizontal_rectangle(
            0.0,
            [0.0, 10.0],
            [0.0, 10.0],
        ))],
        SamplingOptions::for_cutter_radius(5.0),
    )
    .unwrap();
    let tool = ToolAssembly::new(toolpath_collision::Cutter::ball(2.0, 10.0), vec![]).unwrap();
    let up = Pose::new(Vector3::new(0.0, 0.0, 5.0), Vector3::z()).unwrap();
    let down = Pose::new(Vector3::new(0.0, 0.0, 5.0), -Vector3::z()).unwrap();
    assert_eq!(Motion::new(up, down).unwrap_err().field, "to.axis");
    let m = Motion::new(up, up).unwrap();
    let mut o = SweepOptions {
        query: QueryOptions::new(0.01, 1.0),
        tolerance: 0.01,
        max_poses: 100,
    };
    o.query.holder_limit = f64::NAN;
    let e = check_motion(&w, &tool, &m, &o).unwrap_err();
    assert_eq!(e.field, "options.query.holder_limit");
    o.query = QueryOptions::new(0.01, 1.0);
    o.tolerance = 0.0;
    assert_eq!(
        check_motion(&w, &tool, &m, &o).unwrap_err().field,
        "options.tolerance"
    );
}
