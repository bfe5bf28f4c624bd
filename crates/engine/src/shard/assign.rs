//! Which shard runs which case: greedy longest-processing-time (LPT)
//! scheduling on an estimate of each case's work.
//!
//! Cases are taken from the heaviest to the lightest (equal weights in case
//! index order) and each goes to the shard with the least work so far (the
//! lowest shard number among equals). The result depends only on the plan,
//! its input files and N, so every shard computes the same assignment on
//! its own. LPT's makespan is within 4/3 of the best possible (Graham 1969).
//!
//! Weights: a simulated case costs its frames times the ROI rows
//! integrated per frame ([`ledflicker_core::plan::WorkEstimate`]), the same for every
//! case of a plan, so the assignment is round-robin by index (case `i` to
//! shard `i mod N`). A captured case costs the bytes of its capture (a
//! video, Y4M or CSV file, or every file of a frame directory): decoding
//! dominates. A rig case costs 1.

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::path::Path;

use super::ShardSpec;
use ledflicker_core::plan::{BackendKind, Plan, TestCase};

/// Estimated work of each case of `plan`, in plan order (`cases` is
/// [`ledflicker_core::plan::expand_cases`] of it).
pub fn weights(plan: &Plan, cases: &[TestCase]) -> Vec<u64> {
    match plan.dut.backend {
        BackendKind::Simulator => {
            let w = ledflicker_core::plan::WorkEstimate::of(plan);
            let per_case = w.frames_per_case.saturating_mul(w.rows_per_frame).max(1);
            vec![per_case; cases.len()]
        }
        BackendKind::Captured => {
            let sources: std::collections::HashMap<&str, &Path> = plan
                .capture
                .iter()
                .flat_map(|c| &c.cases)
                .map(|c| (c.id.as_str(), c.source.as_path()))
                .collect();
            cases
                .iter()
                .map(|c| sources.get(c.id.as_str()).map_or(1, |p| bytes_of(p).max(1)))
                .collect()
        }
        BackendKind::Command => vec![1; cases.len()],
    }
}

/// Size of a file, or of the files directly in a directory; 0 when missing.
fn bytes_of(path: &Path) -> u64 {
    match std::fs::metadata(path) {
        Ok(m) if m.is_dir() => std::fs::read_dir(path)
            .map(|entries| {
                entries
                    .filter_map(|e| e.ok()?.metadata().ok())
                    .filter(|m| m.is_file())
                    .map(|m| m.len())
                    .sum()
            })
            .unwrap_or(0),
        Ok(m) => m.len(),
        Err(_) => 0,
    }
}

/// The shard (`0..count`) of each case, for cases of these `weights`.
pub fn assign(weights: &[u64], count: usize) -> Vec<usize> {
    let mut order: Vec<usize> = (0..weights.len()).collect();
    order.sort_by_key(|&i| (Reverse(weights[i]), i));
    let mut load: BinaryHeap<Reverse<(u128, usize)>> =
        (0..count.max(1)).map(|s| Reverse((0, s))).collect();
    let mut shard = vec![0; weights.len()];
    for i in order {
        if let Some(Reverse((work, s))) = load.pop() {
            shard[i] = s;
            load.push(Reverse((work + u128::from(weights[i]), s)));
        }
    }
    shard
}

/// The cases of `cases` (all of the plan's, in order) that shard `spec` runs.
pub fn cases_of(plan: &Plan, cases: &[TestCase], spec: ShardSpec) -> Vec<TestCase> {
    let shard = assign(&weights(plan, cases), spec.count);
    cases
        .iter()
        .zip(shard)
        .filter(|(_, s)| *s == spec.index)
        .map(|(c, _)| c.clone())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Makespan of an assignment.
    fn makespan(weights: &[u64], shard: &[usize], count: usize) -> u64 {
        let mut load = vec![0; count];
        for (w, s) in weights.iter().zip(shard) {
            load[*s] += w;
        }
        load.into_iter().max().unwrap_or(0)
    }

    #[test]
    fn equal_weights_go_round_robin() {
        assert_eq!(assign(&[5; 7], 3), vec![0, 1, 2, 0, 1, 2, 0]);
        assert_eq!(assign(&[5; 2], 4), vec![0, 1]);
        assert_eq!(assign(&[], 4), Vec::<usize>::new());
    }

    #[test]
    fn every_case_gets_exactly_one_shard_in_range() {
        let w: Vec<u64> = (0..50).map(|i| (i * 37 % 11) + 1).collect();
        for n in 1..8 {
            let s = assign(&w, n);
            assert_eq!(s.len(), w.len());
            assert!(s.iter().all(|&k| k < n));
        }
    }

    #[test]
    fn lpt_is_within_four_thirds_of_brute_force() {
        // Brute force over every assignment of 9 cases to 3 shards (3^9).
        let w = [17, 3, 9, 11, 2, 8, 13, 5, 7];
        let n = 3;
        let mut best = u64::MAX;
        for code in 0..3usize.pow(9) {
            let shard: Vec<usize> = (0..9).map(|i| code / 3usize.pow(i) % 3).collect();
            best = best.min(makespan(&w, &shard, n));
        }
        let lpt = makespan(&w, &assign(&w, n), n);
        assert!(lpt * 3 <= best * 4, "LPT {lpt}, best {best}");
        // By hand: 17+8, 13+9+3, 11+7+5+2 = 25 each; LPT puts 17+7+2 = 26.
        assert_eq!(best, 25);
        assert_eq!(lpt, 26);
    }

    #[test]
    fn same_input_same_assignment() {
        let w: Vec<u64> = (0..40).map(|i| 1 + (i * 7919 % 13)).collect();
        assert_eq!(assign(&w, 5), assign(&w, 5));
    }
}
