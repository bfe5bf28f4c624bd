use super::*;

fn wrap(body: &str) -> String {
    format!(
        "<svg width=\"100\" height=\"100\" viewBox=\"0 0 100 100\" xmlns=\"http://www.w3.org/2000/svg\">\n{body}</svg>\n"
    )
}

fn circle(cx: f64, cy: f64, r: f64, fill: &str) -> String {
    format!(
        "<circle cx=\"{cx}\" cy=\"{cy}\" r=\"{r}\" opacity=\"1\" fill=\"{fill}\" stroke=\"none\" stroke-width=\"1\"/>\n"
    )
}

fn polyline(points: &str, stroke: &str, width: u32) -> String {
    format!(
        "<polyline fill=\"none\" opacity=\"1\" stroke=\"{stroke}\" stroke-width=\"{width}\" points=\"{points}\"/>\n"
    )
}

/// The tags of `svg`, in order, without the root element.
fn tags(svg: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = svg;
    while let Some(start) = rest.find('<') {
        let len = tag_len(&rest[start..]).unwrap();
        let tag = &rest[start..start + len];
        if !tag.starts_with("<svg") && !tag.starts_with("</svg") {
            out.push(tag.to_string());
        }
        rest = &rest[start + len..];
    }
    out
}

fn attribute<'a>(tag: &'a str, name: &str) -> Option<&'a str> {
    let body = tag.trim_start_matches('<').trim_end_matches("/>");
    let (_, attributes) = body.split_once(' ')?;
    attribute_pairs(attributes)?
        .into_iter()
        .find(|(k, _)| *k == name)
        .map(|(_, v)| v)
}

/// One drawing command of a path's data, with absolute coordinates.
#[derive(Debug, PartialEq)]
enum Segment {
    Move(f64, f64),
    Line(f64, f64),
    Cubic([f64; 6]),
    Close,
}

/// Reads the path data this module writes (M, m, L, c, h, v, H, z and
/// implicit line-tos after M), independently of usvg.
fn segments(d: &str) -> Vec<Segment> {
    let mut out = Vec::new();
    let mut chars = d.char_indices().peekable();
    let mut command = ' ';
    let (mut x, mut y, mut start) = (0.0, 0.0, (0.0, 0.0));
    let mut numbers: Vec<f64> = Vec::new();
    let mut flush = |command: char, numbers: &mut Vec<f64>, out: &mut Vec<Segment>| {
        let n = std::mem::take(numbers);
        match command {
            'M' => {
                for (i, p) in n.chunks(2).enumerate() {
                    (x, y) = (p[0], p[1]);
                    if i == 0 {
                        start = (x, y);
                        out.push(Segment::Move(x, y));
                    } else {
                        out.push(Segment::Line(x, y));
                    }
                }
            }
            'm' => {
                // A move straight after a move only moves the start.
                (x, y) = (x + n[0], y + n[1]);
                start = (x, y);
                if let Some(Segment::Move(..)) = out.last() {
                    out.pop();
                }
                out.push(Segment::Move(x, y));
            }
            'L' => {
                (x, y) = (n[0], n[1]);
                out.push(Segment::Line(x, y));
            }
            'h' => {
                x += n[0];
                out.push(Segment::Line(x, y));
            }
            'v' => {
                y += n[0];
                out.push(Segment::Line(x, y));
            }
            'H' => {
                x = n[0];
                out.push(Segment::Line(x, y));
            }
            'c' => {
                let c = [x + n[0], y + n[1], x + n[2], y + n[3], x + n[4], y + n[5]];
                (x, y) = (c[4], c[5]);
                out.push(Segment::Cubic(c));
            }
            'z' => {
                (x, y) = start;
                out.push(Segment::Close);
            }
            ' ' => assert!(n.is_empty()),
            other => panic!("unexpected command {other}"),
        }
    };
    while let Some((i, c)) = chars.next() {
        if c.is_ascii_alphabetic() && c != 'e' {
            flush(command, &mut numbers, &mut out);
            command = c;
        } else if c == '-' || c == '.' || c.is_ascii_digit() {
            let mut end = i + c.len_utf8();
            while let Some(&(j, n)) = chars.peek() {
                let exponent_sign = n == '-' && d[..j].ends_with('e');
                if n.is_ascii_digit() || n == '.' || n == 'e' || exponent_sign {
                    end = j + 1;
                    chars.next();
                } else {
                    break;
                }
            }
            numbers.push(d[i..end].parse().unwrap());
        }
    }
    flush(command, &mut numbers, &mut out);
    out
}

/// A cubic Bézier at parameter `t`, from `p0`.
fn cubic_at(p0: (f64, f64), c: [f64; 6], t: f64) -> (f64, f64) {
    let u = 1.0 - t;
    let (a, b, cc, d) = (u * u * u, 3.0 * u * u * t, 3.0 * u * t * t, t * t * t);
    (
        a * p0.0 + b * c[0] + cc * c[2] + d * c[4],
        a * p0.1 + b * c[1] + cc * c[3] + d * c[5],
    )
}

#[test]
fn a_run_of_circles_becomes_one_path_of_true_circles() {
    let centres = [(51.0, 170.0), (54.5, 12.25), (-3.0, 7.0)];
    let body: String = centres
        .iter()
        .map(|&(x, y)| circle(x, y, 2.0, "#1F77B4"))
        .collect();
    let out = simplify(&wrap(&body));
    let tags = tags(&out);
    assert_eq!(tags.len(), 1, "{out}");
    assert!(tags[0].starts_with("<path "), "{out}");
    assert_eq!(attribute(&tags[0], "fill"), Some("#1F77B4"));
    assert_eq!(attribute(&tags[0], "stroke"), Some("none"));
    assert_eq!(attribute(&tags[0], "opacity"), None);
    let segs = segments(attribute(&tags[0], "d").unwrap());
    // Per circle: a move to its rightmost point, four quarters, a close.
    assert_eq!(segs.len(), 6 * centres.len(), "{segs:?}");
    for (k, &(cx, cy)) in centres.iter().enumerate() {
        let s = &segs[6 * k..6 * k + 6];
        assert_eq!(s[0], Segment::Move(cx + 2.0, cy));
        assert_eq!(s[5], Segment::Close);
        let mut p0 = (cx + 2.0, cy);
        for (q, seg) in s[1..5].iter().enumerate() {
            let Segment::Cubic(c) = *seg else {
                panic!("{seg:?}")
            };
            // Every point of the quarter lies on the circle (within the
            // approximation's 0.03 %), and the quarters go clockwise on
            // screen: right, bottom, left, top.
            for i in 0..=16 {
                let (x, y) = cubic_at(p0, c, f64::from(i) / 16.0);
                let r = (x - cx).hypot(y - cy);
                assert!(
                    (r - 2.0).abs() < 2.0 * 3e-4,
                    "circle {k} quarter {q}: r {r}"
                );
            }
            let ends = [
                (cx, cy + 2.0),
                (cx - 2.0, cy),
                (cx, cy - 2.0),
                (cx + 2.0, cy),
            ];
            assert!((c[4] - ends[q].0).abs() < 1e-9 && (c[5] - ends[q].1).abs() < 1e-9);
            p0 = (c[4], c[5]);
        }
    }
}

#[test]
fn one_colour_keeps_one_run_across_styles_and_another_colour_ends_it() {
    // A phase fold: a stroked range line, then its two markers, repeated.
    let body = [
        polyline("56,166 56,161", "#1F77B4", 2),
        circle(56.0, 166.0, 2.0, "#1F77B4"),
        circle(56.0, 161.0, 2.0, "#1F77B4"),
        polyline("61,166 61,160 ", "#1F77B4", 2),
        circle(61.0, 166.0, 2.0, "#1F77B4"),
        polyline("1,2 3,4", "#D62728", 2),
        polyline("5,6 7,8", "#D62728", 2),
    ]
    .concat();
    let out = simplify(&wrap(&body));
    let tags = tags(&out);
    assert_eq!(tags.len(), 3, "{out}");
    // The blue strokes, in order, then the blue markers, then the red run.
    assert_eq!(attribute(&tags[0], "stroke"), Some("#1F77B4"));
    assert_eq!(attribute(&tags[0], "fill"), Some("none"));
    assert_eq!(attribute(&tags[0], "stroke-width"), Some("2"));
    assert_eq!(
        attribute(&tags[0], "d"),
        Some("M56,166 56,161M61,166 61,160")
    );
    assert_eq!(attribute(&tags[1], "fill"), Some("#1F77B4"));
    assert_eq!(segments(attribute(&tags[1], "d").unwrap()).len(), 18);
    assert_eq!(attribute(&tags[2], "d"), Some("M1,2 3,4M5,6 7,8"));
    assert_eq!(attribute(&tags[2], "stroke"), Some("#D62728"));
}

#[test]
fn lines_become_subpaths_and_a_lone_shape_stays_as_written() {
    let line = |x1, x2| {
        format!(
            "<line opacity=\"1\" stroke=\"#000000\" stroke-width=\"1\" x1=\"{x1}\" y1=\"5\" x2=\"{x2}\" y2=\"5.5\"/>\n"
        )
    };
    let lone = circle(1.0, 2.0, 3.0, "#00FF00");
    let body = [line(0, 9), line(-1, 4), lone.clone()].concat();
    let out = simplify(&wrap(&body));
    let tags = tags(&out);
    assert_eq!(tags.len(), 2, "{out}");
    assert_eq!(attribute(&tags[0], "d"), Some("M0,5L9,5.5M-1,5L4,5.5"));
    assert_eq!(attribute(&tags[0], "fill"), Some("none"));
    assert_eq!(tags[1], lone.trim());
}

#[test]
fn translucent_shapes_carry_their_opacity_on_the_paint_and_are_not_merged() {
    let grid = "<line opacity=\"0.2\" stroke=\"#000000\" stroke-width=\"1\" x1=\"54\" y1=\"181\" x2=\"54\" y2=\"28\"/>\n";
    let shade = "<rect x=\"62\" y=\"10\" width=\"34\" height=\"195\" opacity=\"0.12\" fill=\"#3C3C3C\" stroke=\"none\"/>\n";
    let band =
        "<polygon opacity=\"0.35\" fill=\"#1F77B4\" points=\"62,24 77,24 78,192 62,24 \"/>\n";
    let out = simplify(&wrap(&[grid, grid, shade, band].concat()));
    let tags = tags(&out);
    assert_eq!(tags.len(), 4, "{out}");
    for tag in &tags[..2] {
        assert!(tag.starts_with("<line "), "{tag}");
        assert_eq!(attribute(tag, "opacity"), None);
        assert_eq!(attribute(tag, "stroke-opacity"), Some("0.2"));
        assert_eq!(attribute(tag, "stroke"), Some("#000000"));
        assert_eq!(attribute(tag, "x1"), Some("54"));
        assert_eq!(attribute(tag, "y2"), Some("28"));
    }
    assert!(tags[2].starts_with("<rect "), "{}", tags[2]);
    assert_eq!(attribute(&tags[2], "fill-opacity"), Some("0.12"));
    assert_eq!(attribute(&tags[2], "stroke-opacity"), None);
    assert_eq!(attribute(&tags[2], "height"), Some("195"));
    assert!(tags[3].starts_with("<polygon "), "{}", tags[3]);
    assert_eq!(attribute(&tags[3], "fill-opacity"), Some("0.35"));
    assert_eq!(
        attribute(&tags[3], "points"),
        Some("62,24 77,24 78,192 62,24 ")
    );
}

#[test]
fn what_this_module_does_not_know_is_left_exactly_as_written() {
    let kept = [
        // Text, a dash pattern, a transform, a stroked and filled circle, a
        // percentage, rounded corners, opaque rectangles and polygons, a
        // filled polyline, an opacity on a shape painted both ways.
        "<text x=\"1\" y=\"2\" opacity=\"1\" fill=\"#000000\">\n0.0\n</text>\n",
        "<polyline fill=\"none\" stroke=\"#000000\" stroke-dasharray=\"2\" points=\"1,2 3,4\"/>\n",
        "<polyline fill=\"none\" stroke=\"#000000\" stroke-dasharray=\"2\" points=\"1,2 3,4\"/>\n",
        "<circle cx=\"1\" cy=\"1\" r=\"2\" fill=\"#000000\" transform=\"scale(2)\"/>\n",
        "<circle cx=\"1\" cy=\"1\" r=\"2\" fill=\"#000000\" stroke=\"#FF0000\"/>\n",
        "<circle cx=\"1\" cy=\"1\" r=\"2\" fill=\"#000000\" stroke=\"#FF0000\"/>\n",
        "<circle cx=\"10%\" cy=\"1\" r=\"2\" fill=\"#000000\" stroke=\"none\"/>\n",
        "<circle cx=\"10%\" cy=\"1\" r=\"2\" fill=\"#000000\" stroke=\"none\"/>\n",
        "<rect x=\"1\" y=\"1\" width=\"2\" height=\"2\" rx=\"1\" fill=\"#000000\"/>\n",
        "<rect x=\"0\" y=\"0\" width=\"2\" height=\"2\" opacity=\"1\" fill=\"#000000\" stroke=\"none\"/>\n",
        "<rect x=\"2\" y=\"0\" width=\"2\" height=\"2\" opacity=\"1\" fill=\"#000000\" stroke=\"none\"/>\n",
        "<polygon fill=\"#000000\" points=\"0,0 4,0 0,4\"/>\n",
        "<polygon fill=\"#000000\" points=\"0,0 4,0 0,4\"/>\n",
        "<polyline stroke=\"#000000\" points=\"0,0 4,0 0,4\"/>\n",
        "<polyline stroke=\"#000000\" points=\"0,0 4,0 0,4\"/>\n",
        "<circle cx=\"1\" cy=\"1\" r=\"2\" opacity=\"0.5\" fill=\"#000000\" stroke=\"#000000\"/>\n",
        "<circle cx=\"1\" cy=\"1\" r=\"0\" fill=\"#000000\"/>\n",
        "<circle cx=\"1\" cy=\"1\" r=\"0\" fill=\"#000000\"/>\n",
    ]
    .concat();
    let svg = wrap(&kept);
    assert_eq!(simplify(&svg), svg);
    // A style sheet could select circles by name: nothing is touched.
    let two = [
        circle(1.0, 1.0, 1.0, "#000000"),
        circle(2.0, 1.0, 1.0, "#000000"),
    ]
    .concat();
    let styled = wrap(&format!("<style>circle {{ fill: red }}</style>\n{two}"));
    assert_eq!(simplify(&styled), styled);
    assert_ne!(simplify(&wrap(&two)), wrap(&two));
}

#[test]
fn a_chart_keeps_all_but_its_shapes_and_gets_fewer_of_them() {
    // A real plotters chart: a phase fold of 32 bins with its envelope.
    let bins: Vec<Option<(f64, f64)>> = (0..32)
        .map(|i| {
            let v = 50.0 + 40.0 * (f64::from(i) * 0.2).sin();
            (i % 7 != 3).then_some((v - 5.0, v + 5.0))
        })
        .collect();
    let svg = crate::charts::phase_fold_svg("roi0", &bins, Some((8.0, 95.0))).unwrap();
    let out = simplify(&svg);
    let shape = |t: &String| {
        [
            "<circle",
            "<line",
            "<polyline",
            "<path",
            "<rect",
            "<polygon",
        ]
        .iter()
        .any(|p| t.starts_with(p))
    };
    let (before, after) = (tags(&svg), tags(&out));
    let others =
        |tags: &[String]| -> Vec<String> { tags.iter().filter(|t| !shape(t)).cloned().collect() };
    assert_eq!(others(&before), others(&after));
    assert!(others(&before).iter().any(|t| t.starts_with("<text")));
    let shapes = |tags: &[String]| tags.iter().filter(|t| shape(t)).count();
    assert!(
        shapes(&after) * 3 < shapes(&before),
        "{} shapes before, {} after:\n{out}",
        shapes(&before),
        shapes(&after)
    );
    // No group opacity is left on a shape; it moved onto the paint.
    assert!(
        !after
            .iter()
            .filter(|t| shape(t))
            .any(|t| { attribute(t, "opacity").is_some_and(|o| o != "1") })
    );
}

#[test]
fn points_and_numbers_are_plain_decimals_and_tags_end_outside_quotes() {
    for ok in ["1,2 3,4", "1,-2", "-0.5,.5 ", " 49,23 49,183 "] {
        assert!(is_points(ok), "{ok}");
    }
    for bad in [
        "", "1,2 3", "1..2,3", "1,2 -", "1e3,2", "1,,2", "1,2;3,4", "1,-,2,3", ",1,2", "1,2,",
    ] {
        assert!(!is_points(bad), "{bad}");
    }
    assert!(is_number("-12.5") && is_positive("0.5") && !is_positive("0.0"));
    assert!(!is_number("1e3") && !is_number("10%") && !is_number("-") && !is_number("1.2.3"));
    assert_eq!(tag_len("<a b=\"x>y\"/> rest"), Some(12));
    assert_eq!(tag_len("<a b='x\">y'/>"), Some(13));
    assert_eq!(tag_len("<a b=\"x/>"), None);
}
