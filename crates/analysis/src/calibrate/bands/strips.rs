//! Column groups: the strips of a frame, left to right, in [`GROUPS`]
//! groups, each estimated alone with its own search (docs/calibration.md,
//! "Column groups"). The largest set of groups whose periods agree within
//! their uncertainty gives the estimate when every group that shows
//! banding is in it; groups without banding are dropped and named. When a
//! banded group disagrees, the frame holds regions that band differently
//! (two lights at different frequencies, or a light and a periodic
//! overlay), and the estimate is refused with each region's columns and
//! period: a period from the whole frame, or from the larger region, could
//! belong to the other light than the frequency given.

use super::{
    BandEstimate, ColumnGroup, MAX_RELATIVE_SIGMA, NoConfidence, StripProfiles, combine_strips,
    estimate_profiles,
};

/// Column groups whose separate estimates are compared.
pub(super) const GROUPS: usize = 4;
/// Two groups agree when their frequencies differ by at most this many
/// combined sigmas...
const AGREE_SIGMAS: f64 = 4.0;
/// ...or by at most this share: the curvature sigma of a clean group can be
/// far below what the scene's structure moves it by.
const AGREE_RELATIVE: f64 = 0.003;

/// One group's strips, columns and estimate: frequency and its sigma,
/// cycles per row.
struct Group {
    strips: std::ops::Range<usize>,
    columns: [u32; 2],
    estimate: Option<(f64, f64)>,
}

/// See the module docs. `columns` gives each strip's pixel columns.
pub(super) fn estimate(
    input: &StripProfiles,
    columns: &[[u32; 2]],
) -> Result<BandEstimate, NoConfidence> {
    let strips = input.first().map_or(0, Vec::len);
    let all: Vec<usize> = (0..strips).collect();
    let groups = GROUPS.min(strips);
    if groups < 2 {
        return estimate_profiles(&profiles_of(input, &all));
    }
    let column = |s: usize| columns.get(s).copied().unwrap_or([s as u32, s as u32 + 1]);
    let groups: Vec<Group> = (0..groups)
        .map(|g| {
            let (a, b) = (g * strips / groups, (g + 1) * strips / groups);
            let strip_list: Vec<usize> = (a..b).collect();
            let estimate = estimate_profiles(&profiles_of(input, &strip_list))
                .ok()
                .map(|e| {
                    (
                        1.0 / e.period_rows,
                        e.period_sigma_rows / e.period_rows.powi(2),
                    )
                });
            Group {
                strips: a..b,
                columns: [column(a)[0], column(b - 1)[1]],
                estimate,
            }
        })
        .collect();
    let banded: Vec<usize> = (0..groups.len())
        .filter(|&g| groups[g].estimate.is_some())
        .collect();
    if banded.len() < 2 {
        // Nothing to compare: the whole frame, as one profile.
        return estimate_profiles(&profiles_of(input, &all));
    }
    let kept = largest_agreeing(&groups, &banded);
    // Any banded group outside the agreeing set bands at a period of its
    // own: a second light at another frequency over part of the frame (or
    // a periodic overlay). The user's frequency belongs to one of them;
    // pairing it with the other's period would give a line time wrong by
    // the ratio of the two frequencies. Refused, each region named.
    if kept.len() < banded.len() {
        return Err(NoConfidence::StripsDisagree {
            regions: regions(&groups, banded),
        });
    }
    let kept_strips: Vec<usize> = kept
        .iter()
        .flat_map(|&g| groups[g].strips.clone())
        .collect();
    let mut est = estimate_profiles(&profiles_of(input, &kept_strips))?;
    let f = 1.0 / est.period_rows;
    let fs: Vec<f64> = kept
        .iter()
        .filter_map(|&g| groups[g].estimate.map(|e| e.0))
        .collect();
    let g = fs.len() as f64;
    let mean = fs.iter().sum::<f64>() / g;
    let var = fs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (g - 1.0);
    let sigma_f = (est.period_sigma_rows * f * f).max((var / g).sqrt());
    let relative_sigma = sigma_f / f;
    if relative_sigma.is_nan() || relative_sigma > MAX_RELATIVE_SIGMA {
        return Err(NoConfidence::Uncertain {
            period_rows: est.period_rows,
            relative_sigma,
        });
    }
    est.period_sigma_rows = relative_sigma * est.period_rows;
    est.group_periods_rows = fs.iter().map(|fg| 1.0 / fg).collect();
    est.dropped = (0..groups.len())
        .filter(|g| !kept.contains(g))
        .map(|g| region(&groups, &[g]))
        .collect();
    Ok(est)
}

/// Each frame's row profile over `strips`: their per-row median.
fn profiles_of(input: &StripProfiles, strips: &[usize]) -> Vec<Vec<f64>> {
    input
        .iter()
        .map(|frame| {
            let chosen: Vec<Vec<f64>> = strips.iter().map(|&s| frame[s].clone()).collect();
            combine_strips(&chosen)
        })
        .collect()
}

/// Whether two estimates (frequency, sigma) agree.
fn agree(a: (f64, f64), b: (f64, f64)) -> bool {
    let d = (a.0 - b.0).abs();
    d <= AGREE_SIGMAS * a.1.hypot(b.1) || d <= AGREE_RELATIVE * a.0.max(b.0)
}

/// The largest set of `candidates` (indices of banded groups) that agree
/// pairwise, in column order; of equally large sets, the one of least
/// relative spread. At most [`GROUPS`] candidates: every subset is tried.
fn largest_agreeing(groups: &[Group], candidates: &[usize]) -> Vec<usize> {
    let est = |g: usize| groups[g].estimate.unwrap_or((f64::NAN, f64::INFINITY));
    let mut best: (Vec<usize>, f64) = (Vec::new(), f64::INFINITY);
    for mask in 1u32..1 << candidates.len() {
        let set: Vec<usize> = (0..candidates.len())
            .filter(|i| mask >> i & 1 == 1)
            .map(|i| candidates[i])
            .collect();
        if set.len() < best.0.len() {
            continue;
        }
        let consistent = set
            .iter()
            .all(|&a| set.iter().all(|&b| a >= b || agree(est(a), est(b))));
        if !consistent {
            continue;
        }
        let fs = set.iter().map(|&g| est(g).0);
        let (lo, hi) = fs.fold((f64::INFINITY, 0.0f64), |(l, h), f| (l.min(f), h.max(f)));
        let spread = (hi - lo) / hi;
        if set.len() > best.0.len() || spread < best.1 {
            best = (set, spread);
        }
    }
    best.0
}

/// The regions of a frame without a majority: the largest agreeing set of
/// the banded groups, then the largest of the rest, and so on; then the
/// groups without banding.
fn regions(groups: &[Group], mut banded: Vec<usize>) -> Vec<ColumnGroup> {
    let mut out = Vec::new();
    while !banded.is_empty() {
        let set = largest_agreeing(groups, &banded);
        banded.retain(|g| !set.contains(g));
        out.push(region(groups, &set));
    }
    let flat: Vec<usize> = (0..groups.len())
        .filter(|&g| groups[g].estimate.is_none())
        .collect();
    if !flat.is_empty() {
        out.push(region(groups, &flat));
    }
    out
}

/// The columns of `set` (adjacent groups merged) and its period: the
/// inverse-variance weighted mean of the groups' frequencies.
fn region(groups: &[Group], set: &[usize]) -> ColumnGroup {
    let mut columns: Vec<[u32; 2]> = Vec::new();
    for &g in set {
        let [a, b] = groups[g].columns;
        match columns.last_mut() {
            Some(last) if last[1] == a => last[1] = b,
            _ => columns.push([a, b]),
        }
    }
    let (mut sw, mut swf) = (0.0, 0.0);
    for e in set.iter().filter_map(|&g| groups[g].estimate) {
        let w = e.1.max(f64::MIN_POSITIVE).powi(-2);
        sw += w;
        swf += w * e.0;
    }
    let period = (sw > 0.0).then(|| sw / swf);
    ColumnGroup {
        columns,
        period_rows: period,
        period_rows_sigma: period.map(|p| p * p / sw.sqrt()),
    }
}
