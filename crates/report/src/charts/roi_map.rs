//! The ROI map: a whole frame at the report's full width with every ROI
//! outlined and named, so that a reader sees what each ROI looks at.
//!
//! The frame is a PNG inside the SVG (display-stretched as the sample
//! frame's view is, box-averaged to at most [`ROI_MAP_WIDTH`] pixels); the
//! outlines and names are SVG shapes and text over it, so the names print
//! at [`super::MIN_TEXT_PT`] or more whatever the frame's size.

use std::fmt::Write as _;

use super::{ChartError, FONT, MIN_TEXT_PT, PDF_TEXT_WIDTH_PT};
use crate::model::RenderedFrame;
use crate::model::RoiKind;
use crate::model::frame::{RoiBox, Stretch};

/// Widest picture of the frame, pixels (the PDF prints it at the text
/// width, about 17 cm).
pub const ROI_MAP_WIDTH: u32 = 960;

const LED_COLOUR: &str = "#d62728";
const BACKGROUND_COLOUR: &str = "#1f77b4";

/// Name size, pixels of the picture: 7.5 pt when printed at the PDF's
/// text width.
fn font_px(width: u32) -> f64 {
    ((MIN_TEXT_PT + 0.5) * f64::from(width) / PDF_TEXT_WIDTH_PT).ceil()
}

/// The ROI map of `frame` with `rois` (source pixels), shown with
/// `stretch`.
pub fn roi_map_svg(
    frame: &RenderedFrame,
    rois: &[RoiBox],
    stretch: &Stretch,
) -> Result<String, ChartError> {
    let picture = crate::frames::view::stretched_frame(frame, stretch, ROI_MAP_WIDTH);
    let (w, h) = picture.dimensions();
    let png = ledflicker_plan::image_io::encode_png(
        picture.as_raw(),
        w,
        h,
        image::ExtendedColorType::Rgb8,
    )
    .map_err(|e| ChartError {
        chart: "ROI map".to_string(),
        message: e.to_string(),
    })?;
    let scale = f64::from(w) / f64::from(frame.width.max(1));
    let fs = font_px(w);
    let mut svg = String::new();
    let _ = write!(
        svg,
        "<svg width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\" xmlns=\"http://www.w3.org/2000/svg\" xmlns:xlink=\"http://www.w3.org/1999/xlink\">\n\
         <image x=\"0\" y=\"0\" width=\"{w}\" height=\"{h}\" xlink:href=\"data:image/png;base64,{}\"/>\n",
        crate::frames::base64(&png)
    );
    for roi in rois {
        let colour = if roi.kind == RoiKind::Led {
            LED_COLOUR
        } else {
            BACKGROUND_COLOUR
        };
        let [x, y, rw, rh] = roi.rect_px.map(|v| f64::from(v) * scale);
        // The outline lies around the ROI, never over its pixels.
        let _ = writeln!(
            svg,
            "<rect x=\"{:.1}\" y=\"{:.1}\" width=\"{:.1}\" height=\"{:.1}\" fill=\"none\" stroke=\"{colour}\" stroke-width=\"2\"/>",
            x - 1.5,
            y - 1.5,
            rw + 3.0,
            rh + 3.0
        );
        // The name on a white label above the ROI, or below it at the top
        // edge, kept inside the picture.
        let text_w = 0.62 * fs * roi.name.chars().count() as f64 + 4.0;
        let lx = x.min(f64::from(w) - text_w).max(0.0);
        let top = if y - fs - 6.0 >= 0.0 {
            y - fs - 6.0
        } else {
            (y + rh + 3.0).min(f64::from(h) - fs - 3.0)
        };
        let _ = writeln!(
            svg,
            "<rect x=\"{lx:.1}\" y=\"{top:.1}\" width=\"{text_w:.1}\" height=\"{:.1}\" fill=\"#ffffff\"/>\n\
             <text x=\"{:.1}\" y=\"{:.1}\" font-family=\"{FONT}\" font-size=\"{fs}\" fill=\"{colour}\">{}</text>",
            fs + 3.0,
            lx + 2.0,
            top + fs - 0.5,
            escape(&roi.name)
        );
    }
    svg.push_str("</svg>\n");
    Ok(svg)
}

/// `text` for SVG character data.
fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_roi_is_outlined_and_named_at_7_pt_or_more() {
        let luma: Vec<f64> = (0..1280 * 800).map(|i| f64::from(i % 256)).collect();
        let frame = RenderedFrame::from_pixels(0, 1280, 800, &luma, 255.0);
        let rois = [
            RoiBox {
                number: 1,
                name: "led".to_string(),
                kind: RoiKind::Led,
                rect_px: [590, 399, 100, 2],
            },
            RoiBox {
                number: 2,
                name: "top-edge".to_string(),
                kind: RoiKind::Background,
                rect_px: [1250, 0, 30, 4],
            },
        ];
        let svg = roi_map_svg(&frame, &rois, &Stretch::of_frame(&frame)).unwrap();
        assert!(
            svg.starts_with("<svg width=\"960\" height=\"600\""),
            "{}",
            &svg[..80]
        );
        assert_eq!(svg.matches("<text ").count(), 2);
        assert!(svg.contains(">led</text>") && svg.contains(">top-edge</text>"));
        // Printed at the text width, the names are at least 7 pt.
        let px: f64 = svg
            .split("font-size=\"")
            .nth(1)
            .unwrap()
            .split('"')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        assert!(px * PDF_TEXT_WIDTH_PT / 960.0 >= MIN_TEXT_PT);
        // The LED ROI (x 590 -> 442.5 at 0.75 scale) outlined in red just
        // around its pixels.
        assert!(svg.contains(&format!("x=\"441.0\" y=\"297.8\" width=\"78.0\" height=\"4.5\" fill=\"none\" stroke=\"{LED_COLOUR}\"")), "{svg}");
        // A name at the top edge goes below its ROI, inside the picture.
        let label_y: f64 = svg
            .split(">top-edge<")
            .next()
            .unwrap()
            .rsplit(" y=\"")
            .next()
            .unwrap()
            .split('"')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        assert!(label_y > 3.0 && label_y < 600.0, "{label_y}");
    }
}
