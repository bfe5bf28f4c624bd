//! A case's sample frame and its worst-phase evidence as results.json
//! describes them, computed from the frames the run kept.

use crate::analysis::worst_phase::WorstPhaseRun;
use crate::model::evidence::*;
use crate::model::frame::*;
use crate::model::{FrameBanding, SampleFrameInfo, frame_path, view_path};
use crate::plan::{Roi, RoiKind};
use crate::trace::RenderedFrame;

/// The model's record of `run`, with its frame's stretch, ROI boxes and
/// caption as for a sample frame.
pub fn worst_phase_info(case_id: &str, run: WorstPhaseRun, plan_rois: &[Roi]) -> WorstPhaseInfo {
    let sample_frame = run.rendered.as_ref().map(|f| SampleFrameInfo {
        path: worst_phase_frame_path(case_id),
        view: worst_phase_view_path(case_id),
        ..sample_frame_info(case_id, f, plan_rois)
    });
    WorstPhaseInfo {
        roi: run.roi,
        metric: run.metric,
        reported: run.reported,
        phase_cycles: run.phase_cycles,
        pwm_delay_ms: run.pwm_delay_s * 1e3,
        frame: run.frame,
        trace: worst_phase_trace_path(case_id),
        fdi_2018: run.fdi_2018,
        percent_flicker: run.percent_flicker,
        luma: run.luma,
        sample_frame,
        rendered: run.rendered,
    }
}

/// Banding of the frame shown, in the columns of the first LED ROI; `None`
/// without an LED ROI or when no row differs from the darkest.
pub fn frame_banding(frame: &RenderedFrame, rois: &[RoiBox]) -> Option<FrameBanding> {
    let [x, _, w, _] = rois.iter().find(|r| r.kind == RoiKind::Led)?.rect_px;
    crate::analysis::banding::frame_banding(frame, x..x.saturating_add(w))
}

/// A spilled case's stand-in for [`sample_frame_info`]: its files and
/// frame number only. Only a case kept in memory is written whole, and
/// that one gets [`sample_frame_info`] once the cases kept are known; the
/// stand-in only says that the case has a sample frame (which the ROI
/// map's choice reads), without working out its stretch and banding.
pub fn sample_frame_pending(case_id: &str, frame: &RenderedFrame) -> SampleFrameInfo {
    SampleFrameInfo {
        path: frame_path(case_id),
        frame: frame.index,
        view: view_path(case_id),
        stretch: Stretch {
            low_dn: 0.0,
            high_dn: 1.0,
        },
        rois: Vec::new(),
        crop_px: None,
        banding: None,
        caption: String::new(),
    }
}

/// What results.json says of a case's sample frame: its files, the
/// display stretch, the ROIs as drawn, the crop, the banding of this very
/// frame and the caption that states them.
pub fn sample_frame_info(
    case_id: &str,
    frame: &RenderedFrame,
    plan_rois: &[Roi],
) -> SampleFrameInfo {
    let rois = RoiBox::from_plan(plan_rois);
    let stretch = Stretch::of_frame(frame);
    let crop_px = crop_rect(&rois, (frame.width, frame.height));
    let banding = frame_banding(frame, &rois);
    let caption = caption(&stretch, &rois, crop_px, banding.as_ref());
    SampleFrameInfo {
        path: frame_path(case_id),
        frame: frame.index,
        view: view_path(case_id),
        stretch,
        rois,
        crop_px,
        banding,
        caption,
    }
}
