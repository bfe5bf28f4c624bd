//! The `result` column of the case store: a case result in CBOR, its
//! per-frame data packed in columns, deflated (docs/store.md, "The case
//! record").
//!
//! A case's frames, luma traces and rendered frames are most of its bytes.
//! As CBOR structs each frame repeats its three field names, each run of a
//! rendered frame its two, and each double is tried at half and single
//! width before it is written; packed, a frame is nine bytes of time and
//! segment, a luma value eight and a run twelve, copied. The store encodes
//! every case of a run and the report stage (and a resume) decodes each,
//! so for small cases this is most of what the store costs.

use serde::de::{self, Deserializer, Visitor};
use serde::{Deserialize, Serialize, Serializer};

use crate::shard::record::ShardCase;
use ledflicker_core::runner::CaseResult;
use ledflicker_core::trace::{FrameInfo, RenderedFrame, Run, Segment};

/// A case as the store holds it.
#[derive(Serialize, Deserialize)]
struct Record {
    /// The case as a shard holds it, less its frames and its ROIs' luma.
    case: ShardCase,
    /// Each frame's `time_s`.
    time_s: Doubles,
    /// Each frame's segment, one byte: `n` ON, `f` OFF, `p` PWM.
    segments: Bytes,
    /// Each frame's index, when the frames are not numbered 0, 1, 2, ...
    index: Option<Vec<u64>>,
    /// Each ROI's luma, in ROI order.
    luma: Vec<Doubles>,
    /// The sample frame.
    sample_frame: Option<Frame>,
    /// The lit frame of a captured case.
    lit_frame: Option<Frame>,
}

/// A rendered frame, its runs packed.
#[derive(Serialize, Deserialize)]
struct Frame {
    index: u64,
    width: u32,
    full_scale_dn: f64,
    /// Runs in each row, top to bottom: a little-endian u32 each.
    row_runs: Bytes,
    /// Every run, row by row, left to right: its pixels (a little-endian
    /// u32), then its value (a little-endian double).
    runs: Bytes,
}

/// Bytes of one packed run.
const RUN_BYTES: usize = 12;

impl Frame {
    fn pack(frame: &RenderedFrame) -> Frame {
        let mut row_runs = Vec::with_capacity(4 * frame.height as usize);
        let mut runs = Vec::new();
        for y in 0..frame.height {
            let row = frame.runs(y);
            row_runs.extend_from_slice(&(row.len() as u32).to_le_bytes());
            for r in row {
                runs.extend_from_slice(&r.len.to_le_bytes());
                runs.extend_from_slice(&r.value.to_le_bytes());
            }
        }
        Frame {
            index: frame.index,
            width: frame.width,
            full_scale_dn: frame.full_scale_dn,
            row_runs: Bytes(row_runs),
            runs: Bytes(runs),
        }
    }

    fn unpack(self) -> Result<RenderedFrame, String> {
        let counts = self.row_runs.0.chunks_exact(4);
        if !counts.remainder().is_empty() {
            return Err(format!(
                "cannot decode: a frame's run counts take {} bytes, not a multiple of 4",
                self.row_runs.0.len()
            ));
        }
        let counts: Vec<usize> = counts.map(|b| le_u32(b) as usize).collect();
        let total = counts.iter().try_fold(0usize, |a, &n| a.checked_add(n));
        if total.and_then(|n| n.checked_mul(RUN_BYTES)) != Some(self.runs.0.len()) {
            return Err(format!(
                "cannot decode: a frame's rows hold {} runs but its runs take {} bytes",
                total.map_or_else(|| "too many".to_string(), |n| n.to_string()),
                self.runs.0.len()
            ));
        }
        let mut packed = self.runs.0.chunks_exact(RUN_BYTES).map(|b| Run {
            len: le_u32(&b[..4]),
            value: f64::from_le_bytes(b[4..].try_into().unwrap_or_default()),
        });
        let rows = counts
            .iter()
            .map(|&n| packed.by_ref().take(n).collect())
            .collect();
        Ok(RenderedFrame::from_runs(
            self.index,
            self.width,
            self.full_scale_dn,
            rows,
        ))
    }
}

fn le_u32(b: &[u8]) -> u32 {
    u32::from_le_bytes(b.try_into().unwrap_or_default())
}

/// Encodes `result` as the store's `result` column.
#[cfg(test)]
pub(super) fn encode(result: CaseResult) -> Result<Vec<u8>, String> {
    encode_plain(result).map(|plain| deflate(&plain))
}

/// The record of `result` before it is deflated: what [`decode_plain`]
/// gives back of a stored record.
pub(super) fn encode_plain(result: CaseResult) -> Result<Vec<u8>, String> {
    let mut case = ShardCase::from_result(result);
    let sample_frame = case.result.sample_frame.take().map(|f| Frame::pack(&f));
    let lit_frame = case.result.lit_frame.take().map(|f| Frame::pack(&f));
    let acquisition = &mut case.result.acquisition;
    let frames = std::mem::take(&mut acquisition.frames);
    let numbered = frames.iter().zip(0u64..).all(|(f, i)| f.index == i);
    let luma = acquisition
        .rois
        .iter_mut()
        .map(|r| Doubles(std::mem::take(&mut r.luma)))
        .collect();
    let record = Record {
        time_s: Doubles(frames.iter().map(|f| f.time_s).collect()),
        segments: Bytes(frames.iter().map(|f| segment_byte(f.segment)).collect()),
        index: (!numbered).then(|| frames.iter().map(|f| f.index).collect()),
        luma,
        case,
        sample_frame,
        lit_frame,
    };
    let mut bytes = Vec::new();
    ciborium::into_writer(&record, &mut bytes).map_err(|e| format!("cannot encode: {e}"))?;
    Ok(bytes)
}

/// A plain record ([`encode_plain`]) as the `result` column holds it.
pub(super) fn deflate(plain: &[u8]) -> Vec<u8> {
    miniz_oxide::deflate::compress_to_vec(plain, DEFLATE_LEVEL)
}

/// The deflate level of a record. A simulated trace repeats a few values
/// and a rendered frame a few runs a row: level 1 shrinks the records of
/// the 2,000-case daylight sweep from 91 kB to 7 kB (12x), and of
/// sweep-23k from 5.0 to 1.2 kB; higher levels take more time for a few
/// per cent more (6: 6.9 kB). The run's workers deflate in parallel.
const DEFLATE_LEVEL: u8 = 1;

/// Most bytes a record inflates to: far above any case (a 60 s capture of
/// 1,800 frames and a few ROIs is under 1 MB), so that a damaged record
/// cannot make the reader allocate without bound.
const INFLATED_MAX: usize = 1 << 30;

/// Decodes the store's `result` column.
pub(super) fn decode(bytes: &[u8]) -> Result<CaseResult, String> {
    decode_plain(bytes).map(|(result, _)| result)
}

/// Decodes the store's `result` column, with the plain record it inflated
/// to.
pub(super) fn decode_plain(bytes: &[u8]) -> Result<(CaseResult, Vec<u8>), String> {
    let bytes = miniz_oxide::inflate::decompress_to_vec_with_limit(bytes, INFLATED_MAX)
        .map_err(|e| format!("cannot inflate: {e}"))?;
    let result = decode_record(&bytes)?;
    Ok((result, bytes))
}

fn decode_record(bytes: &[u8]) -> Result<CaseResult, String> {
    let record: Record = ciborium::from_reader(bytes).map_err(|e| format!("cannot decode: {e}"))?;
    let Record {
        mut case,
        time_s,
        segments,
        index,
        luma,
        sample_frame,
        lit_frame,
    } = record;
    let n = time_s.0.len();
    if segments.0.len() != n || index.as_ref().is_some_and(|i| i.len() != n) {
        return Err(format!(
            "cannot decode: {n} frame times but {} segments",
            segments.0.len()
        ));
    }
    let acquisition = &mut case.result.acquisition;
    if luma.len() != acquisition.rois.len() {
        return Err(format!(
            "cannot decode: {} luma traces for {} ROIs",
            luma.len(),
            acquisition.rois.len()
        ));
    }
    let mut rois = acquisition.rois.iter().zip(&luma);
    if let Some((roi, l)) = rois.find(|(_, l)| l.0.len() != n) {
        return Err(format!(
            "cannot decode: the luma trace of ROI `{}` holds {} values for {n} frames",
            roi.name,
            l.0.len()
        ));
    }
    acquisition.frames = time_s
        .0
        .into_iter()
        .zip(segments.0)
        .enumerate()
        .map(|(i, (time_s, segment))| {
            Ok(FrameInfo {
                index: index.as_ref().map_or(i as u64, |index| index[i]),
                time_s,
                segment: byte_segment(segment)?,
            })
        })
        .collect::<Result<_, String>>()?;
    for (roi, luma) in acquisition.rois.iter_mut().zip(luma) {
        roi.luma = luma.0;
    }
    case.result.sample_frame = sample_frame.map(Frame::unpack).transpose()?;
    case.result.lit_frame = lit_frame.map(Frame::unpack).transpose()?;
    Ok(case.into_result())
}

fn segment_byte(segment: Segment) -> u8 {
    match segment {
        Segment::On => b'n',
        Segment::Off => b'f',
        Segment::Pwm => b'p',
    }
}

fn byte_segment(byte: u8) -> Result<Segment, String> {
    match byte {
        b'n' => Ok(Segment::On),
        b'f' => Ok(Segment::Off),
        b'p' => Ok(Segment::Pwm),
        other => Err(format!("cannot decode: segment byte {other}")),
    }
}

/// Doubles as one CBOR byte string, little-endian: every bit kept.
struct Doubles(Vec<f64>);

impl Serialize for Doubles {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let bytes: Vec<u8> = self.0.iter().flat_map(|x| x.to_le_bytes()).collect();
        s.serialize_bytes(&bytes)
    }
}

impl<'de> Deserialize<'de> for Doubles {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let Bytes(bytes) = Bytes::deserialize(d)?;
        if bytes.len() % 8 != 0 {
            return Err(de::Error::invalid_length(
                bytes.len(),
                &"a multiple of 8 bytes",
            ));
        }
        Ok(Doubles(
            bytes
                .chunks_exact(8)
                .map(|b| f64::from_le_bytes(b.try_into().unwrap_or_default()))
                .collect(),
        ))
    }
}

/// Bytes as one CBOR byte string (serde writes a `Vec<u8>` as an array of
/// integers).
struct Bytes(Vec<u8>);

impl Serialize for Bytes {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(&self.0)
    }
}

impl<'de> Deserialize<'de> for Bytes {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Visit;
        impl Visitor<'_> for Visit {
            type Value = Bytes;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("a byte string")
            }
            fn visit_bytes<E: de::Error>(self, v: &[u8]) -> Result<Bytes, E> {
                Ok(Bytes(v.to_vec()))
            }
            fn visit_byte_buf<E: de::Error>(self, v: Vec<u8>) -> Result<Bytes, E> {
                Ok(Bytes(v))
            }
        }
        d.deserialize_byte_buf(Visit)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A case with every frame field and luma value set to odd bit
    /// patterns, frames not numbered from 0.
    fn odd_case() -> CaseResult {
        let plan = ledflicker_core::plan::find_and_load("daylight").unwrap();
        let cases = ledflicker_core::plan::expand_cases(&plan);
        let backend = ledflicker_core::backend::for_plan(&plan, None).unwrap();
        let mut result =
            ledflicker_core::runner::run(&plan, &cases[..1], &backend, Some(1), &|_| {})
                .unwrap()
                .remove(0);
        let odd = [
            f64::NAN,
            -0.0,
            f64::MIN_POSITIVE / 3.0,
            f64::INFINITY,
            1e300,
        ];
        let acquisition = &mut result.acquisition;
        for (i, f) in acquisition.frames.iter_mut().enumerate() {
            f.index = 7 + 2 * i as u64;
            f.time_s = odd[i % odd.len()];
        }
        for roi in &mut acquisition.rois {
            for (i, v) in roi.luma.iter_mut().enumerate() {
                *v = odd[(i + 1) % odd.len()];
            }
        }
        result
    }

    fn bits(xs: impl Iterator<Item = f64>) -> Vec<u64> {
        xs.map(f64::to_bits).collect()
    }

    #[test]
    fn a_record_gives_back_every_frame_and_luma_bit_for_bit() {
        let plain = odd_case();
        let mut numbered = plain.clone();
        for (i, f) in numbered.acquisition.frames.iter_mut().enumerate() {
            f.index = i as u64;
        }
        for case in [plain, numbered] {
            let back = decode(&encode(case.clone()).unwrap()).unwrap();
            let (a, b) = (&case.acquisition, &back.acquisition);
            assert_eq!(a.frames.len(), b.frames.len());
            for (x, y) in a.frames.iter().zip(&b.frames) {
                assert_eq!((x.index, x.segment), (y.index, y.segment));
                assert_eq!(x.time_s.to_bits(), y.time_s.to_bits());
            }
            for (x, y) in a.rois.iter().zip(&b.rois) {
                assert_eq!(x.name, y.name);
                assert_eq!(bits(x.luma.iter().copied()), bits(y.luma.iter().copied()));
            }
            assert_eq!(format!("{:?}", case.metrics), format!("{:?}", back.metrics));
        }
    }

    /// A frame with an empty row, runs past its width, NaN and signed
    /// zeros: every run of every row comes back bit for bit.
    fn odd_frame(index: u64) -> RenderedFrame {
        let run = |len, value| Run { len, value };
        let rows = vec![
            vec![run(3, -0.0), run(u32::MAX, f64::NAN)],
            vec![],
            vec![
                run(1, f64::MIN_POSITIVE / 3.0),
                run(2, 255.0),
                run(9, 1e300),
            ],
        ];
        RenderedFrame::from_runs(index, 6, 4095.0, rows)
    }

    fn runs_bits(f: &RenderedFrame) -> Vec<Vec<(u32, u64)>> {
        (0..f.height)
            .map(|y| {
                f.runs(y)
                    .iter()
                    .map(|r| (r.len, r.value.to_bits()))
                    .collect()
            })
            .collect()
    }

    #[test]
    fn a_record_gives_back_its_rendered_frames_run_for_run() {
        let mut case = odd_case();
        case.sample_frame = Some(odd_frame(41));
        case.lit_frame = Some(odd_frame(u64::MAX));
        let back = decode(&encode(case.clone()).unwrap()).unwrap();
        for (a, b) in [
            (&case.sample_frame, &back.sample_frame),
            (&case.lit_frame, &back.lit_frame),
        ] {
            let (a, b) = (a.as_ref().unwrap(), b.as_ref().unwrap());
            assert_eq!((a.index, a.width, a.height), (b.index, b.width, b.height));
            assert_eq!(a.full_scale_dn.to_bits(), b.full_scale_dn.to_bits());
            assert_eq!(runs_bits(a), runs_bits(b));
        }
        case.lit_frame = None;
        let back = decode(&encode(case).unwrap()).unwrap();
        assert!(back.sample_frame.is_some() && back.lit_frame.is_none());
    }

    #[test]
    fn a_frame_whose_runs_do_not_match_its_rows_is_an_error() {
        let mut case = odd_case();
        case.sample_frame = Some(odd_frame(0));
        let cbor = miniz_oxide::inflate::decompress_to_vec(&encode(case).unwrap()).unwrap();
        let record: Record = ciborium::from_reader(cbor.as_slice()).unwrap();
        let frame = record.sample_frame.as_ref().unwrap();
        assert_eq!(frame.runs.0.len(), 5 * RUN_BYTES);
        let damaged = |edit: &dyn Fn(&mut Frame)| {
            let mut record: Record = ciborium::from_reader(cbor.as_slice()).unwrap();
            edit(record.sample_frame.as_mut().unwrap());
            let mut bytes = Vec::new();
            ciborium::into_writer(&record, &mut bytes).unwrap();
            decode(&deflate(&bytes)).unwrap_err()
        };
        let e = damaged(&|f| {
            f.runs.0.pop();
        });
        assert!(e.contains("5 runs but its runs take 59 bytes"), "{e}");
        let e = damaged(&|f| f.row_runs.0[0] = 9);
        assert!(e.contains("12 runs"), "{e}");
        let e = damaged(&|f| f.row_runs.0.truncate(5));
        assert!(e.contains("not a multiple of 4"), "{e}");
        let e = damaged(&|f| f.row_runs.0[..4].copy_from_slice(&u32::MAX.to_le_bytes()));
        assert!(e.contains("runs take 60 bytes"), "{e}");
    }

    #[test]
    fn a_damaged_record_is_an_error_not_a_panic() {
        let bytes = encode(odd_case()).unwrap();
        for cut in [0, 1, bytes.len() / 2, bytes.len() - 1] {
            assert!(decode(&bytes[..cut]).is_err(), "cut at {cut}");
        }
        let cbor = miniz_oxide::inflate::decompress_to_vec(&bytes).unwrap();
        let mut record: Record = ciborium::from_reader(cbor.as_slice()).unwrap();
        record.segments.0[0] = b'x';
        let mut bad = Vec::new();
        ciborium::into_writer(&record, &mut bad).unwrap();
        let bad = miniz_oxide::deflate::compress_to_vec(&bad, DEFLATE_LEVEL);
        let e = decode(&bad).unwrap_err();
        assert!(e.contains("segment byte 120"), "{e}");
        record.segments.0.pop();
        let mut short = Vec::new();
        ciborium::into_writer(&record, &mut short).unwrap();
        let short = miniz_oxide::deflate::compress_to_vec(&short, DEFLATE_LEVEL);
        let e = decode(&short).unwrap_err();
        assert!(e.contains("segments"), "{e}");
        let mut record: Record = ciborium::from_reader(cbor.as_slice()).unwrap();
        record.luma[1].0.pop();
        let mut cut = Vec::new();
        ciborium::into_writer(&record, &mut cut).unwrap();
        let e = decode(&deflate(&cut)).unwrap_err();
        let (roi, n) = (&odd_case().acquisition.rois[1].name, record.time_s.0.len());
        let want = format!(
            "the luma trace of ROI `{roi}` holds {} values for {n} frames",
            n - 1
        );
        assert!(e.contains(&want), "{e}");
    }
}
