//! The shard directory format (`ledflicker.shard/2`), written by a shard
//! run and read back typed by `merge`:
//!
//! - `shard.json`: the [`Manifest`] (plan hash, tool version, seed, shard
//!   K/N, the case indices it ran, the inputs, the SHA-256 of `cases.cbor`);
//! - `cases.cbor`: every [`ShardCase`] in case order, CBOR (RFC 8949),
//!   which stores each f64 exactly, so the merged report is computed from
//!   the very numbers the shard measured;
//! - `traces/<case>.csv`: the traces, as in a report, for people.
//!
//! The types here are the start of one typed results model read back typed.

use std::path::Path;

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use super::ShardSpec;
use ledflicker_core::inputs::InputFile;
use ledflicker_core::runner::CaseResult;

/// Schema of `shard.json`.
pub const SCHEMA: &str = "ledflicker.shard/2";
/// The manifest's file name.
pub const MANIFEST: &str = "shard.json";
/// The case results' file name.
pub const CASES: &str = "cases.cbor";

/// `shard.json`: what a shard ran, and of what.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// [`SCHEMA`].
    pub schema: String,
    /// `ledflicker <version>` of the binary that ran the shard.
    pub tool: String,
    /// Plan id.
    pub plan_id: String,
    /// The plan's path as the shard resolved it (as in results.json).
    pub plan_path: String,
    /// The same, absolute, for a merge run from another directory.
    pub plan_path_absolute: String,
    /// [`plan_hash`] of the plan and every input it names.
    pub plan_hash: String,
    /// The plan's seed.
    pub seed: u64,
    /// Backend id.
    pub backend: String,
    /// This shard.
    pub shard: ShardSpec,
    /// Cases in the whole plan.
    pub case_count: usize,
    /// Indices of the cases this shard ran, ascending.
    pub cases: Vec<usize>,
    /// Every input of the plan, as results.json lists them.
    pub inputs: Vec<InputRecord>,
    /// SHA-256 of `cases.cbor`, lowercase hex.
    pub cases_sha256: String,
}

/// One input file (results.json `report.inputs`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct InputRecord {
    /// Role, e.g. "plan".
    pub role: String,
    /// Path as the run saw it.
    pub path: String,
    /// SHA-256, lowercase hex.
    pub sha256: String,
    /// Size in bytes.
    pub size: u64,
}

impl From<&InputFile> for InputRecord {
    fn from(f: &InputFile) -> Self {
        Self {
            role: f.role.clone(),
            path: f.path.clone(),
            sha256: f.sha256.clone(),
            size: f.size,
        }
    }
}

impl From<&InputRecord> for InputFile {
    fn from(r: &InputRecord) -> Self {
        Self {
            role: r.role.clone(),
            path: r.path.clone(),
            sha256: r.sha256.clone(),
            size: r.size,
        }
    }
}

/// One case as a shard ran it: everything the report stage reads.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShardCase {
    /// The case result (metrics, traces, segments, verdict, sample frame,
    /// and what a captured or rig case read).
    pub result: CaseResult,
    /// The capture's segment-detection signal, which results.json leaves
    /// out (`SegmentsFound::signal`) but the trace chart draws.
    pub capture_signal: Vec<(f64, f64)>,
}

impl ShardCase {
    /// The record of `result`, its capture signal moved out of the summary
    /// (which does not serialise it) into the record.
    pub fn from_result(mut result: CaseResult) -> ShardCase {
        let capture_signal = result
            .acquisition
            .capture
            .as_mut()
            .map(|s| std::mem::take(&mut s.segments.signal))
            .unwrap_or_default();
        ShardCase {
            result,
            capture_signal,
        }
    }

    /// The case result, its capture signal put back.
    pub fn into_result(mut self) -> CaseResult {
        if let Some(s) = &mut self.result.acquisition.capture {
            s.segments.signal = self.capture_signal;
        }
        self.result
    }
}

/// Hash identifying a plan and its inputs: SHA-256 over each input's role,
/// SHA-256 and size (not its path, which may differ between machines), in
/// the order [`ledflicker_core::inputs::collect`] lists them, the plan first.
pub fn plan_hash(inputs: &[InputFile]) -> String {
    let mut h = Sha256::new();
    for i in inputs {
        h.update(format!("{}\0{}\0{}\n", i.role, i.sha256, i.size).as_bytes());
    }
    ledflicker_core::util::hex(&h.finalize())
}

/// CBOR bytes of `cases`.
pub fn encode_cases(cases: &[ShardCase]) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    ciborium::into_writer(cases, &mut out).map_err(|e| e.to_string())?;
    Ok(out)
}

/// Reads `cases.cbor` back; `path` names it in errors.
pub fn decode_cases(bytes: &[u8], path: &Path) -> Result<Vec<ShardCase>, String> {
    let mut cases: Vec<ShardCase> = ciborium::from_reader(bytes).map_err(|e| {
        format!(
            "`{}` is not a readable shard case file: {e}",
            path.display()
        )
    })?;
    for c in &mut cases {
        if let Some(s) = &mut c.result.acquisition.capture {
            s.segments.signal = std::mem::take(&mut c.capture_signal);
        }
    }
    Ok(cases)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ledflicker_core::backend::{Acquisition, FrameInfo, RenderedFrame, RoiTrace};
    use ledflicker_core::metrics::Verdict;
    use ledflicker_core::metrics::flicker::Segment;
    use ledflicker_core::plan::TestCase;

    /// Awkward f64s: shortest decimal forms that naive parsers round wrong,
    /// subnormals, signed zero, infinities, and the extremes.
    const AWKWARD: [f64; 10] = [
        0.1,
        f64::MIN_POSITIVE,
        f64::from_bits(1),
        -0.0,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::MAX,
        1.0 / 3.0,
        9_007_199_254_740_992.0,
        0.30000000000000004,
    ];

    fn case_with(values: &[f64]) -> ShardCase {
        let n = values.len();
        ShardCase {
            result: CaseResult {
                case: TestCase {
                    index: 3,
                    id: "100lux-90hz-50pct".into(),
                    light_lux: 100.0,
                    frequency_hz: 90.0,
                    duty: 0.5,
                    seed: u64::MAX - 7,
                },
                acquisition: Acquisition {
                    frames: (0..n as u64)
                        .map(|i| FrameInfo {
                            index: i,
                            time_s: values[i as usize],
                            segment: Segment::Pwm,
                        })
                        .collect(),
                    rois: vec![RoiTrace {
                        name: "led".into(),
                        luma: values.to_vec(),
                        phase_envelope: Some((values[0], values[1])),
                        rgb: None,
                    }],
                    saturation_dn: 254.5,
                    capture: None,
                },
                metrics: Vec::new(),
                verdict: Verdict::Info,
                checks: Vec::new(),
                not_judged: Some("why".into()),
                not_checked: vec!["x".into()],
                sample_frame: Some(RenderedFrame::from_pixels(
                    2,
                    2,
                    (n / 2) as u32,
                    values,
                    255.0,
                )),
                p2020: Vec::new(),
                lit_frame: None,
            },
            capture_signal: Vec::new(),
        }
    }

    fn bits(c: &ShardCase) -> Vec<u64> {
        let r = &c.result;
        let mut out: Vec<u64> = r.acquisition.rois[0]
            .luma
            .iter()
            .map(|x| x.to_bits())
            .collect();
        out.extend(r.acquisition.frames.iter().map(|f| f.time_s.to_bits()));
        out.extend(
            r.sample_frame
                .iter()
                .flat_map(|f| (0..f.height).flat_map(|y| f.row(y)))
                .map(|x| x.to_bits()),
        );
        out
    }

    #[test]
    fn every_f64_round_trips_bit_for_bit() {
        let mut values = AWKWARD.to_vec();
        // And a pseudo-random spread over the exponent range.
        let mut x = 0x9e37_79b9_7f4a_7c15_u64;
        for _ in 0..2000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let v = f64::from_bits(x);
            if v.is_finite() {
                values.push(v);
            }
        }
        let original = case_with(&values);
        let bytes = encode_cases(std::slice::from_ref(&original)).unwrap();
        let back = decode_cases(&bytes, Path::new("cases.cbor")).unwrap();
        assert_eq!(back.len(), 1);
        assert_eq!(bits(&back[0]), bits(&original));
        assert_eq!(back[0].result.case, original.result.case);
        assert_eq!(back[0].result.not_checked, original.result.not_checked);
    }

    #[test]
    fn a_damaged_file_is_an_error_naming_it() {
        let bytes = encode_cases(&[case_with(&AWKWARD)]).unwrap();
        let e = decode_cases(&bytes[..bytes.len() / 2], Path::new("s/cases.cbor")).unwrap_err();
        assert!(e.contains("s/cases.cbor"), "{e}");
    }

    #[test]
    fn plan_hash_ignores_paths_but_not_contents() {
        let f = |path: &str, sha: &str| InputFile {
            role: "plan".into(),
            path: path.into(),
            sha256: sha.into(),
            size: 10,
        };
        assert_eq!(
            plan_hash(&[f("a.toml", "00")]),
            plan_hash(&[f("/x/a.toml", "00")])
        );
        assert_ne!(
            plan_hash(&[f("a.toml", "00")]),
            plan_hash(&[f("a.toml", "01")])
        );
    }
}
