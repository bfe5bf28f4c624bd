//! Whole frames as grey pixels, for the analyses that need pixels rather
//! than ROI means (ROI detection): [`FrameSink`] receives each
//! [`GreyFrame`] of [`super::read_grey_frames`].

use super::{FrameView, LumaWeights, Pixels};

/// Receives every frame of a capture as grey pixels, for the analyses that
/// need pixels rather than ROI means ([`super::read_grey_frames`]).
pub trait FrameSink {
    /// Frame `frame` (0-based), whole, as the ROI means see it.
    fn frame(&mut self, frame: &GreyFrame<'_>);
}

/// One frame's grey image as the ROI means see it: the plan's luma weights
/// on RGB, limited-range Y' expanded to full range.
pub struct GreyFrame<'a> {
    pub(super) view: &'a FrameView<'a>,
    pub(super) weights: LumaWeights,
    pub(super) expand: Option<&'a [u32]>,
    /// 0-based frame number.
    pub index: u64,
}

impl GreyFrame<'_> {
    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.view.width
    }

    /// Rows held (the whole frame's height).
    pub fn height(&self) -> u32 {
        let w = self.view.width.max(1) as usize;
        let samples = match &self.view.pixels {
            Pixels::Grey8(p) => p.len(),
            Pixels::Grey16(p) => p.len(),
            Pixels::Rgb8(p, c) => p.len() / c,
            Pixels::Rgb16(p, c) => p.len() / c,
        };
        (samples / w) as u32
    }

    /// The grey values of row `y` (0 = the frame's top) into `out`, which
    /// holds [`GreyFrame::width`] values.
    pub fn row(&self, y: u32, out: &mut [u32]) {
        let w = self.view.width as usize;
        let base = (y - self.view.origin.1) as usize * w;
        let lut = |v: u32| self.expand.map_or(v, |l| l[v as usize]);
        match &self.view.pixels {
            Pixels::Grey8(p) => {
                for (o, &v) in out.iter_mut().zip(&p[base..base + w]) {
                    *o = lut(u32::from(v));
                }
            }
            Pixels::Grey16(p) => {
                for (o, &v) in out.iter_mut().zip(&p[base..base + w]) {
                    *o = lut(u32::from(v));
                }
            }
            Pixels::Rgb8(p, c) => {
                for (o, px) in out
                    .iter_mut()
                    .zip(p[base * c..(base + w) * c].chunks_exact(*c))
                {
                    *o = self.weights.luma(px[0].into(), px[1].into(), px[2].into());
                }
            }
            Pixels::Rgb16(p, c) => {
                for (o, px) in out
                    .iter_mut()
                    .zip(p[base * c..(base + w) * c].chunks_exact(*c))
                {
                    *o = self.weights.luma(px[0].into(), px[1].into(), px[2].into());
                }
            }
        }
    }
}
