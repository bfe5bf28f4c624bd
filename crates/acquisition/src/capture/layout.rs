//! Where FFmpeg cuts a video frame for the ROIs: one tile per ROI with a
//! 2-pixel margin on even coordinates, stacked into one narrow picture, or
//! the ROIs' bounding box as the one tile; and the cut of a frame too large
//! to clamp any tile, with which ffmpeg starts before ffprobe answers
//! (`video`).

use super::{RoiRect, bounding_box};

/// Where FFmpeg cuts the frame: tiles of the frame, each `width` wide,
/// stacked top to bottom into a `width` x `height` picture, and the ROIs in
/// that picture's coordinates (same order as the plan's).
#[derive(Debug, PartialEq)]
pub(super) struct Layout {
    /// Frame rectangles, top to bottom.
    pub(super) tiles: Vec<RoiRect>,
    pub(super) width: u32,
    pub(super) height: u32,
    pub(super) rois: Vec<RoiRect>,
}

/// At most this many tiles; more ROIs are read through their bounding box.
const MAX_TILES: usize = 256;

/// Width and height of the frame [`Layout::speculative`] assumes. ROIs
/// that end within half of it get tiles that no edge clamps or moves.
const ANY_FRAME: u32 = 1 << 20;

impl Layout {
    /// One tile per ROI when that halves the pixels or better, else the
    /// bounding box (the whole frame without ROIs) as one tile.
    pub(super) fn for_rois(rois: &[RoiRect], frame: (u32, u32)) -> Layout {
        let whole = RoiRect {
            x: 0,
            y: 0,
            width: frame.0,
            height: frame.1,
        };
        let bbox = with_margin(&bounding_box(rois).unwrap_or(whole), frame);
        let area = |t: &[RoiRect]| {
            t.iter()
                .map(|r| r.width as u64 * r.height as u64)
                .sum::<u64>()
        };
        let tiles = (2..=MAX_TILES)
            .contains(&rois.len())
            .then(|| tiles_per_roi(rois, frame))
            .flatten()
            .filter(|tiles| 2 * area(tiles) <= area(std::slice::from_ref(&bbox)));
        if let Some(tiles) = tiles {
            return Layout::stacked(tiles, rois);
        }
        Layout::single(bbox, rois)
    }

    /// The layout of `rois` in a frame large enough that no edge clamps a
    /// tile: the layout of every frame in which no tile reaches an edge.
    /// `None` without ROIs (the layout is then the whole frame) or for ROIs
    /// beyond half of [`ANY_FRAME`].
    pub(super) fn speculative(rois: &[RoiRect]) -> Option<Layout> {
        let half = u64::from(ANY_FRAME / 2);
        let inside = |r: &RoiRect| {
            u64::from(r.x) + u64::from(r.width) <= half
                && u64::from(r.y) + u64::from(r.height) <= half
        };
        (!rois.is_empty() && rois.iter().all(inside))
            .then(|| Layout::for_rois(rois, (ANY_FRAME, ANY_FRAME)))
    }

    /// `tiles[i]` holds `rois[i]`; stacked in that order.
    pub(super) fn stacked(tiles: Vec<RoiRect>, rois: &[RoiRect]) -> Layout {
        let width = tiles.first().map_or(0, |t| t.width);
        let mut top = 0;
        let mut mapped = Vec::with_capacity(rois.len());
        for (t, r) in tiles.iter().zip(rois) {
            mapped.push(RoiRect {
                x: r.x - t.x,
                y: r.y - t.y + top,
                ..*r
            });
            top += t.height;
        }
        Layout {
            height: top,
            width,
            tiles,
            rois: mapped,
        }
    }

    /// One tile, `tile`, holding every ROI.
    pub(super) fn single(tile: RoiRect, rois: &[RoiRect]) -> Layout {
        let rois = rois
            .iter()
            .map(|r| RoiRect {
                x: r.x - tile.x,
                y: r.y - tile.y,
                ..*r
            })
            .collect();
        Layout {
            width: tile.width,
            height: tile.height,
            tiles: vec![tile],
            rois,
        }
    }

    /// The filter graph from the first video stream to `[out]`: crop each
    /// tile (no copy), stack the tiles, then `suffix`.
    pub(super) fn filter(&self, suffix: &str) -> String {
        self.filter_from("[0:v:0]", suffix)
    }

    /// [`Layout::filter`] from the stream labelled `input` (with brackets).
    pub(super) fn filter_from(&self, input: &str, suffix: &str) -> String {
        let crop = |t: &RoiRect| format!("crop={}:{}:{}:{}", t.width, t.height, t.x, t.y);
        if let [tile] = self.tiles.as_slice() {
            return format!("{input}{}{suffix}[out]", crop(tile));
        }
        let n = self.tiles.len();
        let mut g = format!("{input}split={n}");
        (0..n).for_each(|i| g.push_str(&format!("[s{i}]")));
        for (i, t) in self.tiles.iter().enumerate() {
            g.push_str(&format!(";[s{i}]{}[c{i}]", crop(t)));
        }
        g.push(';');
        (0..n).for_each(|i| g.push_str(&format!("[c{i}]")));
        g.push_str(&format!("vstack=inputs={n}{suffix}[out]"));
        g
    }
}

/// `r` plus a 2-pixel margin, on even coordinates (4:2:0 chroma sites),
/// clipped to the frame, so that cutting it out changes no pixel.
pub(super) fn with_margin(r: &RoiRect, frame: (u32, u32)) -> RoiRect {
    let x0 = r.x.saturating_sub(2) & !1;
    let y0 = r.y.saturating_sub(2) & !1;
    let x1 = ((r.x + r.width + 3) & !1).min(frame.0);
    let y1 = ((r.y + r.height + 3) & !1).min(frame.1);
    RoiRect {
        x: x0,
        y: y0,
        width: x1 - x0,
        height: y1 - y0,
    }
}

/// One tile per ROI, all as wide as the widest (stacking needs one width),
/// moved left where they would pass the frame's right edge; `None` when a
/// tile cannot hold its ROI that way.
fn tiles_per_roi(rois: &[RoiRect], frame: (u32, u32)) -> Option<Vec<RoiRect>> {
    let mut tiles: Vec<RoiRect> = rois.iter().map(|r| with_margin(r, frame)).collect();
    let width = tiles.iter().map(|t| t.width).max()?;
    if width > frame.0 || width % 2 == 1 {
        return None;
    }
    for (t, r) in tiles.iter_mut().zip(rois) {
        t.x = t.x.min((frame.0 - width) & !1);
        t.width = width;
        let holds = t.x <= r.x && r.x + r.width <= t.x + t.width;
        if !holds || t.height % 2 == 1 || t.y % 2 == 1 {
            return None;
        }
    }
    Some(tiles)
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    pub(in crate::capture) fn rect(x: u32, y: u32, width: u32, height: u32) -> RoiRect {
        RoiRect {
            x,
            y,
            width,
            height,
        }
    }

    /// ROIs far apart, one odd-placed, one at the right and bottom edges.
    pub(in crate::capture) fn spread_rois() -> Vec<RoiRect> {
        vec![
            rect(457, 247, 20, 2),
            rect(101, 33, 7, 3),
            rect(1270, 797, 10, 3),
            rect(640, 500, 13, 9),
        ]
    }

    #[test]
    fn spread_rois_get_one_even_tile_each_and_map_into_it() {
        let (w, h) = (1280, 800);
        let rois = spread_rois();
        let layout = Layout::for_rois(&rois, (w, h));
        assert_eq!(layout.tiles.len(), rois.len());
        let mut top = 0;
        for ((t, r), m) in layout.tiles.iter().zip(&rois).zip(&layout.rois) {
            assert_eq!(t.width, layout.width);
            assert!(t.x % 2 == 0 && t.y % 2 == 0 && t.height % 2 == 0, "{t:?}");
            assert!(t.x + t.width <= w && t.y + t.height <= h);
            // The ROI sits in its tile, at the same place in the stack.
            assert_eq!((m.x + t.x, m.y - top + t.y), (r.x, r.y));
            assert_eq!((m.width, m.height), (r.width, r.height));
            assert!(m.x + m.width <= t.width && m.y + m.height <= top + t.height);
            top += t.height;
        }
        assert_eq!(layout.height, top);
        let g = layout.filter(",extractplanes=y");
        assert!(
            g.starts_with("[0:v:0]split=4[s0][s1][s2][s3];[s0]crop="),
            "{g}"
        );
        assert!(g.ends_with("[c0][c1][c2][c3]vstack=inputs=4,extractplanes=y[out]"));
    }

    #[test]
    fn close_rois_and_a_single_roi_use_the_bounding_box() {
        let (w, h) = (1280, 800);
        for rois in [
            vec![rect(100, 100, 50, 40), rect(150, 100, 50, 40)],
            vec![rect(457, 247, 20, 2)],
        ] {
            let layout = Layout::for_rois(&rois, (w, h));
            assert_eq!(layout.tiles.len(), 1);
            let t = layout.tiles[0];
            for (r, m) in rois.iter().zip(&layout.rois) {
                assert_eq!((m.x + t.x, m.y + t.y), (r.x, r.y));
            }
            assert_eq!(
                layout.filter(""),
                format!("[0:v:0]crop={}:{}:{}:{}[out]", t.width, t.height, t.x, t.y)
            );
        }
    }

    /// The speculative layout is the frame's own when no tile reaches an
    /// edge, and differs (so is not used) when one does.
    #[test]
    fn the_speculative_layout_is_the_frames_unless_a_tile_reaches_an_edge() {
        let inner = vec![rect(457, 247, 20, 2), rect(101, 33, 7, 3)];
        let spec = Layout::speculative(&inner).unwrap();
        assert_eq!(spec, Layout::for_rois(&inner, (1280, 800)));
        assert_eq!(spec, Layout::for_rois(&inner, (480, 252)));
        // The tile of ROI 1 would pass x = 478 and is clamped or moved.
        assert_ne!(spec, Layout::for_rois(&inner, (478, 252)));
        // Bottom edge: the 2-pixel margin below row 249 is cut.
        assert_ne!(spec, Layout::for_rois(&inner, (480, 250)));
        let edge = spread_rois();
        assert_ne!(
            Layout::speculative(&edge).unwrap(),
            Layout::for_rois(&edge, (1280, 800))
        );
        assert!(Layout::speculative(&[]).is_none());
        assert!(Layout::speculative(&[rect(ANY_FRAME / 2, 0, 1, 1)]).is_none());
        assert!(Layout::speculative(&[rect(u32::MAX, u32::MAX, u32::MAX, 1)]).is_none());
    }
}
