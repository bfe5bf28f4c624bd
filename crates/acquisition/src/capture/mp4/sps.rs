//! The picture size an H.264 stream states in its sequence parameter set
//! (ITU-T H.264, 7.3.2.1.1), after its frame cropping: the size a decoder,
//! and ffprobe, give its frames.

/// Reads bits of an RBSP (the emulation-prevention bytes already removed),
/// most significant first.
struct Bits<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Bits<'_> {
    fn bit(&mut self) -> Option<u32> {
        let byte = self.bytes.get(self.at / 8)?;
        let bit = (byte >> (7 - self.at % 8)) & 1;
        self.at += 1;
        Some(u32::from(bit))
    }

    fn bits(&mut self, n: u32) -> Option<u32> {
        (0..n).try_fold(0u32, |v, _| Some((v << 1) | self.bit()?))
    }

    /// ue(v): an Exp-Golomb code of at most 32 leading zeros.
    fn ue(&mut self) -> Option<u32> {
        let mut zeros = 0;
        while self.bit()? == 0 {
            zeros += 1;
            if zeros > 31 {
                return None;
            }
        }
        let rest = self.bits(zeros)?;
        u32::try_from((1u64 << zeros) - 1 + u64::from(rest)).ok()
    }

    /// se(v): only skipped here.
    fn se(&mut self) -> Option<()> {
        self.ue().map(|_| ())
    }
}

/// The NAL unit's payload without its emulation-prevention bytes (the
/// `03` of every `00 00 03`).
fn rbsp(nal: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(nal.len());
    let mut zeros = 0;
    for &b in nal {
        if zeros >= 2 && b == 3 {
            zeros = 0;
            continue;
        }
        zeros = if b == 0 { zeros + 1 } else { 0 };
        out.push(b);
    }
    out
}

/// Width and height of the pictures of the sequence parameter set `nal`
/// (with its one-byte NAL header). None for anything else, and where
/// FFmpeg would not crop as the set says: a crop from the left or the top
/// (FFmpeg may narrow a left crop to keep its rows aligned), or a crop
/// larger than the picture (FFmpeg then ignores it).
pub(super) fn picture_size(nal: &[u8]) -> Option<(u32, u32)> {
    if nal.first()? & 0x1f != 7 {
        return None;
    }
    let data = rbsp(nal.get(1..)?);
    let mut b = Bits {
        bytes: &data,
        at: 0,
    };
    let profile = b.bits(8)?;
    b.bits(16)?; // constraint flags, level
    b.ue()?; // seq_parameter_set_id
    let mut chroma_format = 1;
    let mut separate_planes = false;
    // The profiles whose sets carry the chroma format, as FFmpeg reads them:
    // it also counts 144 (the withdrawn High 4:4:4) and not 134, 135 and
    // 139 (MFC and multi-resolution profiles, which the standard lists). A
    // set of those three would be read unlike FFmpeg, so it is not read.
    if matches!(profile, 134 | 135 | 139) {
        return None;
    }
    if matches!(
        profile,
        100 | 110 | 122 | 244 | 44 | 83 | 86 | 118 | 128 | 138 | 144
    ) {
        chroma_format = b.ue()?;
        if chroma_format > 3 {
            return None;
        }
        if chroma_format == 3 {
            separate_planes = b.bit()? == 1;
        }
        b.ue()?; // bit_depth_luma_minus8
        b.ue()?; // bit_depth_chroma_minus8
        b.bit()?; // qpprime_y_zero_transform_bypass_flag
        if b.bit()? == 1 {
            let lists = if chroma_format == 3 { 12 } else { 8 };
            for i in 0..lists {
                if b.bit()? == 1 {
                    skip_scaling_list(&mut b, if i < 6 { 16 } else { 64 })?;
                }
            }
        }
    }
    b.ue()?; // log2_max_frame_num_minus4
    match b.ue()? {
        0 => {
            b.ue()?; // log2_max_pic_order_cnt_lsb_minus4
        }
        1 => {
            b.bit()?; // delta_pic_order_always_zero_flag
            b.se()?; // offset_for_non_ref_pic
            b.se()?; // offset_for_top_to_bottom_field
            // num_ref_frames_in_pic_order_cnt_cycle: 0-255; FFmpeg refuses
            // a set with more.
            let cycle = b.ue()?;
            if cycle > 255 {
                return None;
            }
            for _ in 0..cycle {
                b.se()?; // offset_for_ref_frame
            }
        }
        _ => {}
    }
    b.ue()?; // max_num_ref_frames
    b.bit()?; // gaps_in_frame_num_value_allowed_flag
    let width_mbs = u64::from(b.ue()?) + 1;
    let height_units = u64::from(b.ue()?) + 1;
    let frames_only = b.bit()? == 1;
    if !frames_only {
        b.bit()?; // mb_adaptive_frame_field_flag
    }
    b.bit()?; // direct_8x8_inference_flag
    let [left, right, top, bottom] = if b.bit()? == 1 {
        [b.ue()?, b.ue()?, b.ue()?, b.ue()?].map(u64::from)
    } else {
        [0; 4]
    };
    if left != 0 || top != 0 {
        return None;
    }
    // Table 6-1 and equations 7-19 to 7-22.
    let field = if frames_only { 1 } else { 2 };
    let (unit_x, unit_y) = match (chroma_format, separate_planes) {
        (0, _) | (3, true) => (1, field),
        (1, false) => (2, 2 * field),
        (2, false) => (2, field),
        _ => (1, field),
    };
    let width = (width_mbs * 16).checked_sub(unit_x * right)?;
    let height = (field * height_units * 16).checked_sub(unit_y * bottom)?;
    if width == 0 || height == 0 {
        return None;
    }
    Some((u32::try_from(width).ok()?, u32::try_from(height).ok()?))
}

/// Skips a scaling list of `size` entries (7.3.2.1.1.1).
fn skip_scaling_list(b: &mut Bits<'_>, size: usize) -> Option<()> {
    let (mut last, mut next) = (8i64, 8i64);
    for _ in 0..size {
        if next != 0 {
            let code = i64::from(b.ue()?);
            // se(v): 1, 2, 3, 4 ... map to 1, -1, 2, -2 ...
            let delta = if code % 2 == 1 {
                (code + 1) / 2
            } else {
                -(code / 2)
            };
            next = (last + delta + 256).rem_euclid(256);
        }
        if next != 0 {
            last = next;
        }
    }
    Some(())
}
