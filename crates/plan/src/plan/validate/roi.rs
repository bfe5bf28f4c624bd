//! `[[roi]]`: the regions of interest, checked against the camera's sensor
//! or, in a captured plan, against each capture's frame. Messages name a
//! ROI by its `name`; its key path counts `[[roi]]` tables from 0
//! (`roi[0]` is the first), as every key path of a plan does, and so does
//! the default name (`roi0`).

use std::path::Path;

use crate::plan::check::Checker;
use crate::plan::raw::RawRoi;
use crate::plan::{CameraConfig, CaptureCase, FrameSize, Roi, RoiKind};
use crate::trace::TRACE_COLUMNS;

/// Default ROI size from Deegan 2018: 100 px wide, 2 rows high (a taller ROI
/// mixes ON and OFF rows of a rolling shutter).
const DEFAULT_ROI_WIDTH_PX: u32 = 100;
const DEFAULT_ROI_HEIGHT_PX: u32 = 2;

/// Validates `[[roi]]`. With no ROI, one LED ROI of the default size in the
/// middle of the sensor; a plan without a sensor (`has_sensor` false: a
/// captured or command plan without `[dut.camera]` or a profile) must list
/// its ROIs, as only the frames read at run time say where the middle is.
/// `camera` is `None` when it is invalid; the ROIs are then checked on
/// their own and the result is `None`.
pub(super) fn rois(
    c: &mut Checker<'_>,
    raw: Vec<RawRoi>,
    camera: Option<&CameraConfig>,
    has_sensor: bool,
) -> Option<Vec<Roi>> {
    if raw.is_empty() && !has_sensor {
        c.error_near(
            "roi",
            "dut.backend",
            "a plan that reads its frames from captures or a rig needs at least one [[roi]]",
            Some("add [[roi]] with name, x-px and y-px for each light to measure (the default ROI is centred on [dut.camera]'s sensor, which this plan does not have)"),
        );
        return None;
    }
    if raw.is_empty() {
        return Some(vec![default_roi(camera?)]);
    }
    let mut out = Vec::new();
    let mut ok = true;
    for (i, r) in raw.into_iter().enumerate() {
        match roi(c, r, i, &out, &mut ok) {
            Some(roi) => {
                if let Some(cam) = camera {
                    ok &= fits_sensor(c, &roi, i, cam);
                }
                out.push(roi);
            }
            None => ok = false,
        }
    }
    (ok && camera.is_some()).then_some(out)
}

/// One LED ROI of 100 x 2 px in the middle of the sensor.
fn default_roi(cam: &CameraConfig) -> Roi {
    let w = DEFAULT_ROI_WIDTH_PX.min(cam.sensor_columns);
    let h = DEFAULT_ROI_HEIGHT_PX.min(cam.sensor_rows);
    Roi {
        name: "led".to_string(),
        kind: RoiKind::Led,
        x_px: (cam.sensor_columns - w) / 2,
        y_px: (cam.sensor_rows - h) / 2,
        width_px: w,
        height_px: h,
    }
}

/// `[[roi]]` number `i`; `earlier` are the ROIs before it. A bad name
/// clears `ok` but keeps the ROI; a bad kind or position is `None`.
fn roi(c: &mut Checker<'_>, r: RawRoi, i: usize, earlier: &[Roi], ok: &mut bool) -> Option<Roi> {
    let k = |s: &str| format!("roi[{i}].{s}");
    let name = r.name.unwrap_or_else(|| format!("roi{i}"));
    if name.is_empty()
        || !name
            .chars()
            .all(|ch| ch.is_ascii_alphanumeric() || ch == '-' || ch == '_')
    {
        c.error(
            &k("name"),
            format!("ROI name `{name}` must be letters, digits, `-` or `_`"),
            Some("the name is a CSV column header"),
        );
        *ok = false;
    } else if let Some(column) = TRACE_COLUMNS
        .iter()
        .find(|col| col.eq_ignore_ascii_case(&name))
    {
        c.error(
            &k("name"),
            format!("ROI name `{name}` is taken by the trace CSV's `{column}` column"),
            Some(&format!(
                "a trace has the columns {}, then one per ROI; give the ROI another name, e.g. \"led\"",
                TRACE_COLUMNS.join(", ")
            )),
        );
        *ok = false;
    } else if earlier.iter().any(|o| o.name == name) {
        c.error(
            &k("name"),
            format!("ROI name `{name}` is used twice"),
            Some("give each ROI its own name"),
        );
        *ok = false;
    }
    let kind = match r.kind.as_deref() {
        None | Some("led") => Some(RoiKind::Led),
        Some("background") => Some(RoiKind::Background),
        Some(other) => {
            c.error(
                &k("kind"),
                format!("unknown ROI kind `{other}`"),
                Some("use \"led\" or \"background\""),
            );
            None
        }
    };
    let hint = "ROI position in pixels, 0-based from the top-left corner";
    let x = c
        .required(r.x_px, &k("x-px"), hint)
        .and_then(|v| c.pixels(v, &k("x-px"), 0));
    let y = c
        .required(r.y_px, &k("y-px"), hint)
        .and_then(|v| c.pixels(v, &k("y-px"), 0));
    let w = c.pixels(
        r.width_px.unwrap_or(DEFAULT_ROI_WIDTH_PX as i64),
        &k("width-px"),
        1,
    );
    let h = c.pixels(
        r.height_px.unwrap_or(DEFAULT_ROI_HEIGHT_PX as i64),
        &k("height-px"),
        1,
    );
    Some(Roi {
        name,
        kind: kind?,
        x_px: x?,
        y_px: y?,
        width_px: w?,
        height_px: h?,
    })
}

/// Whether `roi` (number `i`) lies on the sensor; reports each side that
/// does not.
fn fits_sensor(c: &mut Checker<'_>, roi: &Roi, i: usize, cam: &CameraConfig) -> bool {
    let k = |s: &str| format!("roi[{i}].{s}");
    let mut ok = true;
    let (x, y, w, h) = (roi.x_px, roi.y_px, roi.width_px, roi.height_px);
    let name = &roi.name;
    if x as u64 + w as u64 > cam.sensor_columns as u64 {
        c.error(
            &k("x-px"),
            format!(
                "ROI `{name}` columns {x}..{} fall outside the sensor's {} columns",
                x as u64 + w as u64,
                cam.sensor_columns
            ),
            Some("x-px + width-px must not exceed dut.camera.sensor-columns"),
        );
        ok = false;
    }
    if y as u64 + h as u64 > cam.sensor_rows as u64 {
        c.error(
            &k("y-px"),
            format!(
                "ROI `{name}` rows {y}..{} fall outside the sensor's {} rows",
                y as u64 + h as u64,
                cam.sensor_rows
            ),
            Some("y-px + height-px must not exceed dut.camera.sensor-rows"),
        );
        ok = false;
    }
    ok
}

/// Captures whose frame size is read at the same time.
const PROBED_AT_ONCE: usize = 8;

/// Reports each ROI that does not lie on the frame of every capture of
/// `cases`, whose frame sizes `read` takes from a header or a probe,
/// never by decoding. A capture whose size cannot be read now is left to
/// the run, which says why; each source is read once.
pub(super) fn fit_captures(
    c: &mut Checker<'_>,
    rois: &[Roi],
    cases: &[CaptureCase],
    read: FrameSize<'_>,
) {
    let mut sources: Vec<(&Path, &str)> = Vec::new();
    for case in cases {
        if !sources.iter().any(|(p, _)| *p == case.source.as_path()) {
            sources.push((&case.source, &case.id));
        }
    }
    // A video's size may take an ffprobe process (where its header alone
    // does not settle it): read together, a plan of several videos waits
    // for one probe, not one after another.
    let mut frames: Vec<(&Path, (u32, u32), &str)> = Vec::new();
    for group in sources.chunks(PROBED_AT_ONCE) {
        let sizes: Vec<Option<(u32, u32)>> = std::thread::scope(|s| {
            let probes: Vec<_> = group
                .iter()
                .map(|&(p, _)| s.spawn(move || read(p)))
                .collect();
            probes
                .into_iter()
                .map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
                .collect()
        });
        for (&(source, id), size) in group.iter().zip(sizes) {
            if let Some(size) = size {
                frames.push((source, size, id));
            }
        }
    }
    for (i, roi) in rois.iter().enumerate() {
        let right = roi.x_px as u64 + roi.width_px as u64;
        let bottom = roi.y_px as u64 + roi.height_px as u64;
        let outside: Vec<_> = frames
            .iter()
            .filter(|(_, (w, h), _)| right > *w as u64 || bottom > *h as u64)
            .collect();
        let Some(&&(source, (w, h), id)) = outside.first() else {
            continue;
        };
        let others = match outside.len() - 1 {
            0 => String::new(),
            1 => " and 1 other capture".to_string(),
            n => format!(" and {n} other captures"),
        };
        let side = if right > w as u64 { "x-px" } else { "y-px" };
        c.error(
            &format!("roi[{i}].{side}"),
            format!(
                "ROI `{}` (columns {}..{right}, rows {}..{bottom}) falls outside the {w}x{h} frame of capture `{}` (case `{id}`){others}",
                roi.name,
                roi.x_px,
                roi.y_px,
                source.display(),
            ),
            Some(&format!(
                "pixels are 0-based: x-px + width-px must be at most {w} and y-px + height-px at most {h}"
            )),
        );
    }
}
