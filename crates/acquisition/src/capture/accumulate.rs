//! The ROI means of each frame: luma, and the colour planes when the
//! frames have colour.

use super::{
    ColourTransfer, FrameSink, FrameView, GreyFrame, LumaWeights, Pixels, RgbTraces, RoiRect,
    progress,
};

/// Accumulates ROI means frame by frame, and hands each frame to a
/// [`FrameSink`] when one is given.
pub(crate) struct Accumulator<'r> {
    rois: &'r [RoiRect],
    weights: LumaWeights,
    /// Map from Y' code to full-range grey, for limited-range luma planes.
    pub expand: Option<Vec<u32>>,
    luma: Vec<Vec<f64>>,
    rgb: Vec<Vec<[f64; 3]>>,
    colour: bool,
    /// Code -> linear light of 8-bit and 16-bit R, G, B codes, for the
    /// colour planes; `None`: the codes are linear.
    linear: Option<(Vec<f64>, Vec<f64>)>,
    frames: usize,
    sink: Option<&'r mut dyn FrameSink>,
}

impl<'r> Accumulator<'r> {
    pub fn new(rois: &'r [RoiRect], weights: LumaWeights) -> Self {
        Self {
            rois,
            weights,
            expand: None,
            luma: vec![Vec::new(); rois.len()],
            rgb: vec![Vec::new(); rois.len()],
            colour: false,
            linear: None,
            frames: 0,
            sink: None,
        }
    }

    /// The accumulator whose colour planes are the means of the codes'
    /// linear light under `transfer`, on the codes' own scale (255 or 65535
    /// at full scale); the luma stays the codes' mean.
    pub fn linearising(mut self, transfer: ColourTransfer) -> Self {
        let table = |full: f64| -> Vec<f64> {
            let n = full as usize + 1;
            (0..n)
                .map(|code| full * transfer.linear(code as f64 / full))
                .collect()
        };
        self.linear = (transfer != ColourTransfer::Linear).then(|| (table(255.0), table(65535.0)));
        self
    }

    /// The accumulator that also hands every frame to `sink`; its views
    /// must then hold whole frames.
    pub fn with_sink<'s: 'r>(mut self, sink: Option<&'r mut (dyn FrameSink + 's)>) -> Self {
        self.sink = sink.map(|s| s as &'r mut (dyn FrameSink + 'r));
        self
    }

    /// Adds one frame. The view must cover every ROI.
    pub fn push(&mut self, view: &FrameView<'_>) {
        progress::count_frame();
        if let Some(sink) = self.sink.as_deref_mut() {
            sink.frame(&GreyFrame {
                view,
                weights: self.weights,
                expand: self.expand.as_deref(),
                index: self.frames as u64,
            });
        }
        self.frames += 1;
        let w = self.weights;
        let stride = view.width as usize;
        for (i, r) in self.rois.iter().enumerate() {
            let n = (r.width as u64 * r.height as u64) as f64;
            let x0 = (r.x - view.origin.0) as usize;
            let (mut sy, mut planes) = (0u64, [0u64; 3]);
            // The planes' sums of linear light, when the codes are not.
            let mut lin = [0.0f64; 3];
            for row in r.y..r.y + r.height {
                let base = (row - view.origin.1) as usize * stride + x0;
                let cols = base..base + r.width as usize;
                match &view.pixels {
                    Pixels::Grey8(p) => match &self.expand {
                        Some(lut) => {
                            sy += p[cols].iter().map(|&v| lut[v as usize] as u64).sum::<u64>()
                        }
                        None => sy += p[cols].iter().map(|&v| v as u64).sum::<u64>(),
                    },
                    Pixels::Grey16(p) => match &self.expand {
                        Some(lut) => {
                            sy += p[cols].iter().map(|&v| lut[v as usize] as u64).sum::<u64>()
                        }
                        None => sy += p[cols].iter().map(|&v| v as u64).sum::<u64>(),
                    },
                    Pixels::Rgb8(p, c) => {
                        let lut = self.linear.as_ref().map(|l| &l.0[..]);
                        let row = &p[cols.start * c..cols.end * c];
                        add_rgb(row, *c, w, (&mut sy, &mut planes), (lut, &mut lin));
                    }
                    Pixels::Rgb16(p, c) => {
                        let lut = self.linear.as_ref().map(|l| &l.1[..]);
                        let row = &p[cols.start * c..cols.end * c];
                        add_rgb(row, *c, w, (&mut sy, &mut planes), (lut, &mut lin));
                    }
                }
            }
            self.luma[i].push(sy as f64 / n);
            if matches!(view.pixels, Pixels::Rgb8(..) | Pixels::Rgb16(..)) {
                self.colour = true;
                let means = match self.linear {
                    Some(_) => lin.map(|s| s / n),
                    None => planes.map(|s| s as f64 / n),
                };
                self.rgb[i].push(means);
            }
        }
    }

    /// Frames pushed so far.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// The luma traces and, when every frame had colour, the RGB traces.
    pub fn finish(self) -> (Vec<Vec<f64>>, Option<RgbTraces>) {
        let n = self.frames();
        let rgb = (self.colour && self.rgb.iter().all(|t| t.len() == n)).then_some(self.rgb);
        (self.luma, rgb)
    }
}

/// Adds a row of RGB pixels (`c` samples each, R, G, B first) to the luma
/// sum and the planes' code sums, and, when the codes are not linear, the
/// planes' light through `lut` to `lin`.
fn add_rgb<T: Copy + Into<u32>>(
    row: &[T],
    c: usize,
    w: LumaWeights,
    (sy, planes): (&mut u64, &mut [u64; 3]),
    (lut, lin): (Option<&[f64]>, &mut [f64; 3]),
) {
    for px in row.chunks_exact(c) {
        let [r, g, b]: [u32; 3] = [px[0].into(), px[1].into(), px[2].into()];
        *sy += w.luma(r, g, b) as u64;
        for (s, v) in planes.iter_mut().zip([r, g, b]) {
            *s += u64::from(v);
        }
        if let Some(lut) = lut {
            for (s, v) in lin.iter_mut().zip([r, g, b]) {
                *s += lut[v as usize];
            }
        }
    }
}
