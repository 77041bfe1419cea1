//! The node's view of `/joint_states` (sensor_msgs/JointState): the latest
//! position of every joint by name, with its arrival time, so a trajectory
//! starts where the machine is. Several publishers (one broadcaster per
//! machine, or one for the cell) may each name some joints.

use std::collections::BTreeMap;
use std::sync::Mutex;
use std::time::{Duration, Instant};
use toolpath_kernel::error::{Error, Result};
use toolpath_machines::{controller, Axis};
use toolpath_messages as msgs;

/// Metres per mm: JointState carries metres and radians (REP 103).
const MM: f64 = 1e-3;

#[derive(Default)]
pub struct JointStates {
    latest: Mutex<BTreeMap<String, (f64, Instant)>>,
}

impl JointStates {
    /// Takes in one message received at `now`. A message whose lists do not
    /// match is refused whole, naming what is wrong.
    pub fn update(&self, m: &msgs::JointState, now: Instant) -> Result<()> {
        if m.position.len() != m.name.len() {
            return Err(Error::invalid(
                "joint_states.position",
                format!("has {} values for {} names", m.position.len(), m.name.len()),
            ));
        }
        let mut latest = match self.latest.lock() {
            Ok(g) => g,
            Err(p) => p.into_inner(),
        };
        for (n, x) in m.name.iter().zip(&m.position) {
            latest.insert(n.clone(), (*x, now));
        }
        Ok(())
    }

    /// Where the machine with joints `names` (and `limits`) is, mm and rad:
    /// `None` when none of its joints has ever been reported (the trajectory
    /// starts from the home pose). Errors say which joint is missing, stale
    /// (older than `max_age`) or outside its travel.
    pub fn start_pose(
        &self,
        machine: &str,
        names: &[String],
        limits: &[Axis],
        max_age: Duration,
        now: Instant,
    ) -> Result<Option<Vec<f64>>> {
        let latest = match self.latest.lock() {
            Ok(g) => g,
            Err(p) => p.into_inner(),
        };
        let known: Vec<Option<&(f64, Instant)>> = names.iter().map(|n| latest.get(n)).collect();
        if known.iter().all(|k| k.is_none()) {
            return Ok(None);
        }
        let mut q = Vec::with_capacity(names.len());
        for ((name, k), l) in names.iter().zip(&known).zip(limits) {
            let Some((x, at)) = k else {
                let have: Vec<&str> = names
                    .iter()
                    .zip(&known)
                    .filter(|(_, k)| k.is_some())
                    .map(|(n, _)| n.as_str())
                    .collect();
                return Err(Error::planning(format!(
                    "{machine}: joint_states has no joint {name} (it reports {} of this machine's joints {}): \
                     the trajectory cannot start from a partly known pose",
                    have.join(" "),
                    names.join(" ")
                )));
            };
            let age = now.saturating_duration_since(*at);
            if age > max_age {
                return Err(Error::planning(format!(
                    "{machine}: the joint state of {name} is stale: last received {:.1} s ago, more than \
                     controller.joint_states_max_age_s = {} s (is the joint state broadcaster running?)",
                    age.as_secs_f64(),
                    max_age.as_secs_f64()
                )));
            }
            q.push(if l.rotary { *x } else { x / MM });
        }
        controller::check_start(&format!("{machine}: the joint state"), &q, limits, names)?;
        Ok(Some(q))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use toolpath_machines::Mill5Config;

    fn state(names: &[&str], position: &[f64]) -> msgs::JointState {
        msgs::JointState {
            name: names.iter().map(|s| s.to_string()).collect(),
            position: position.to_vec(),
            ..Default::default()
        }
    }

    #[test]
    fn joint_states_give_the_start_pose_or_a_reason() {
        let cfg = Mill5Config::default();
        let (names, limits) = (cfg.joint_names(), cfg.limits());
        let js = JointStates::default();
        let t0 = Instant::now();
        let age = Duration::from_secs(1);
        let pose = |now| js.start_pose("mill5", &names, &limits, age, now);
        // Nothing known: the home pose.
        assert_eq!(pose(t0).unwrap(), None);
        // Another machine's joints only: still nothing known of this one.
        js.update(&state(&["belt_x"], &[1.0]), t0).unwrap();
        assert_eq!(pose(t0).unwrap(), None);
        // Part of the machine: the missing joint is named.
        js.update(&state(&["X", "Y", "Z", "A"], &[2.5, 1.0, 1.2, 0.1]), t0)
            .unwrap();
        let e = pose(t0).unwrap_err().to_string();
        assert!(
            e.contains("mill5: joint_states has no joint C (it reports X Y Z A of this machine's joints X Y Z A C)"),
            "{e}"
        );
        // Complete, in m and rad: mm and rad out.
        js.update(&state(&["C"], &[-0.5]), t0).unwrap();
        let q = pose(t0).unwrap().unwrap();
        assert_eq!(q, vec![2500.0, 1000.0, 1200.0, 0.1, -0.5]);
        // Stale after max_age.
        let e = pose(t0 + Duration::from_millis(1500))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("mill5: the joint state of X is stale: last received 1.5 s ago, more than controller.joint_states_max_age_s = 1 s"),
            "{e}"
        );
        // Outside the travel.
        js.update(&state(&["Z"], &[1.6]), t0).unwrap();
        let e = pose(t0).unwrap_err().to_string();
        assert!(
            e.contains("mill5: the joint state has joint Z (axis Z) at 1600.000 mm, outside its range 0..1500 mm"),
            "{e}"
        );
        // A malformed message is refused whole.
        let e = js
            .update(&state(&["X", "Y"], &[1.0]), t0)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("joint_states.position: has 1 values for 2 names"),
            "{e}"
        );
    }
}
