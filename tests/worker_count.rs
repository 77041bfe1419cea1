//! A node plans each job whole on one of its `node.workers` threads, and the
//! workers share only what is keyed by its whole input (the path-length lower
//! bound's cache, the shapes). So a job's result must be the same bytes
//! whatever the worker count: the same jobs planned one after another on one
//! thread, and taken from one queue by 2 and by 4 threads at once (racing for
//! those caches), give identical JSON.
//!
//! More lower-bound keys than the cache keeps, so that each run computes
//! some of them again while other threads read and evict entries.

use std::sync::atomic::{AtomicUsize, Ordering};
use toolpath_planner::cli::bench_node::iso_parametric_job;
use toolpath_planner::formats::{Job, PlanResult, Strategy};
use toolpath_planner::pipeline::{self, RunOptions};
use toolpath_planner::planners::NoProgress;
use toolpath_planner::samples;

fn jobs() -> Vec<Job> {
    let mut jobs: Vec<Job> = (0..12)
        .map(|k| {
            let h = 0.015 * (k + 1) as f64;
            iso_parametric_job(&format!("plane_{k}"), samples::surfaces::plane(), h).unwrap()
        })
        .collect();
    let mut cylinder = samples::job("concave_cylinder").unwrap();
    cylinder.strategy = Strategy::IsoScallop;
    jobs.push(cylinder);
    jobs.push(samples::job("pocket_with_hole").unwrap());
    jobs.push(samples::job("sine_wave").unwrap());
    jobs
}

fn result_bytes(job: &Job) -> Vec<u8> {
    let result = pipeline::run(job, &NoProgress, RunOptions::PLAN_ONLY).unwrap();
    serde_json::to_vec(&result).unwrap()
}

/// The jobs' results, in job order, planned by `workers` threads taking the
/// next job from a shared queue (as the node's workers do).
fn planned_by(workers: usize, jobs: &[Job]) -> Vec<Vec<u8>> {
    let next = AtomicUsize::new(0);
    let mut done: Vec<(usize, Vec<u8>)> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..workers)
            .map(|_| {
                scope.spawn(|| {
                    let mut mine = Vec::new();
                    loop {
                        let k = next.fetch_add(1, Ordering::Relaxed);
                        let Some(job) = jobs.get(k) else { break };
                        mine.push((k, result_bytes(job)));
                    }
                    mine
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap())
            .collect()
    });
    done.sort_by_key(|(k, _)| *k);
    assert_eq!(done.len(), jobs.len());
    done.into_iter().map(|(_, bytes)| bytes).collect()
}

#[test]
fn results_are_the_same_bytes_whatever_the_worker_count() {
    let jobs = jobs();
    let four = planned_by(4, &jobs);
    let one = planned_by(1, &jobs);
    let two = planned_by(2, &jobs);
    for (k, job) in jobs.iter().enumerate() {
        assert!(!one[k].is_empty());
        assert!(four[k] == one[k], "{}: 4 workers differ from 1", job.job_id);
        assert!(two[k] == one[k], "{}: 2 workers differ from 1", job.job_id);
    }
    // Each plane job got the lower bound of its own scallop (a cache hit of
    // another key would repeat a value): a larger h allows wider strips
    // (up to h = 0.2, where the strip reaches the full cutter width).
    let bounds: Vec<f64> = one[..12]
        .iter()
        .map(|bytes| {
            let r: PlanResult = serde_json::from_slice(bytes).unwrap();
            r.stats.path_length_lower_bound_mm.unwrap()
        })
        .collect();
    for pair in bounds.windows(2) {
        assert!(
            pair[1] < pair[0],
            "lower bounds not decreasing in h: {bounds:?}"
        );
    }
}
