//! Visual regression of the reports. The key PDF pages (cover, summary, a
//! matrix, a failing case, sign-off) of a small plan are rendered to grey
//! PNGs at 30 dpi with `pdftoppm` and compared with the references in
//! tests/integration/visual/ within a stated tolerance, as typst's own test
//! suite compares its rendered pages with reference images. The HTML report
//! is loaded in headless Chromium: its screenshot must show a page, and the
//! page must log nothing to the console (no script error).
//!
//! On a mismatch the test writes `<page>.actual.png` and `<page>.diff.png`
//! (differing pixels red) next to the reference and names them.
//! `VISUAL_UPDATE=1 cargo test --test integration visual` rewrites the
//! references; look at them before committing.

use std::path::{Path, PathBuf};
use std::process::Command;

use image::{GrayImage, Rgb, RgbImage};

use crate::{ledflicker, root, scratch, text};

/// A pixel differs when its grey levels differ by more than this...
const GREY_TOLERANCE: u8 = 48;
/// ...and a page differs when more than this share of its pixels differ.
/// A changed heading or a moved table at 30 dpi changes far more than this;
/// anti-aliasing of another poppler version changes far less.
const MAX_DIFFERING: f64 = 0.0015;
/// Rendering resolution of the compared pages.
const DPI: &str = "30";

/// The compared pages: reference name and the texts that find the page
/// (the first page whose text contains all of them), so that pages may move.
/// The failing case's id alone would also find the Cases index.
const PAGES: [(&str, &[&str]); 5] = [
    ("cover", &["LED FLICKER CONFORMANCE TEST REPORT"]),
    ("summary", &["Executive summary"]),
    ("matrix", &["Frequency × duty matrices"]),
    ("failing-case", &["2000lux-60hz-20pct", "Apparent flicker"]),
    ("signoff", &["Sign-off"]),
];

fn reference_dir() -> PathBuf {
    root().join("tests/integration/visual")
}

/// Runs the small failing plan (4 cases, one fails) with a fixed date.
fn small_report(name: &str) -> PathBuf {
    let dir = scratch(name);
    let o = ledflicker(&[
        "plan",
        "tests/fixtures/plans/small_failing.toml",
        "--out",
        dir.to_str().unwrap(),
        "--date",
        "2026-01-15",
        "-q",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    dir
}

fn tool(program: &str, args: &[&str]) -> Vec<u8> {
    let o = Command::new(program)
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("{program} not found ({e}): scripts/test.sh installs it"));
    assert!(o.status.success(), "{program} {args:?}: {}", text(&o));
    o.stdout
}

/// The 1-based number of the first page of `pdf` whose text has every one
/// of `needles`.
fn page_with(pdf: &Path, pages: usize, needles: &[&str]) -> usize {
    let pdf = pdf.to_str().unwrap();
    (1..=pages)
        .find(|k| {
            let k = k.to_string();
            let t = tool("pdftotext", &["-f", &k, "-l", &k, pdf, "-"]);
            let t = String::from_utf8_lossy(&t);
            needles.iter().all(|n| t.contains(n))
        })
        .unwrap_or_else(|| panic!("no page of {pdf} contains all of {needles:?}"))
}

fn page_count(pdf: &Path) -> usize {
    let info = String::from_utf8(tool("pdfinfo", &[pdf.to_str().unwrap()])).unwrap();
    info.lines()
        .find_map(|l| l.strip_prefix("Pages:"))
        .and_then(|n| n.trim().parse().ok())
        .unwrap_or_else(|| panic!("no page count in pdfinfo output: {info}"))
}

/// Page `k` of `pdf` as a grey image at [`DPI`].
pub(crate) fn render(pdf: &Path, k: usize, out: &Path) -> GrayImage {
    let k = k.to_string();
    let prefix = out.with_extension("");
    tool(
        "pdftoppm",
        &[
            "-r",
            DPI,
            "-gray",
            "-png",
            "-singlefile",
            "-f",
            &k,
            "-l",
            &k,
            pdf.to_str().unwrap(),
            prefix.to_str().unwrap(),
        ],
    );
    image::open(out).unwrap().to_luma8()
}

/// Share of pixels that differ by more than [`GREY_TOLERANCE`], and the
/// diff image (reference faint, differing pixels red); `None` when the
/// sizes differ.
fn compare(actual: &GrayImage, reference: &GrayImage) -> Option<(f64, RgbImage)> {
    if actual.dimensions() != reference.dimensions() {
        return None;
    }
    let (w, h) = actual.dimensions();
    let mut diff = RgbImage::new(w, h);
    let mut differing = 0usize;
    for (x, y, a) in actual.enumerate_pixels() {
        let r = reference.get_pixel(x, y)[0];
        let faint = 191 + r / 4;
        if a[0].abs_diff(r) > GREY_TOLERANCE {
            differing += 1;
            diff.put_pixel(x, y, Rgb([220, 0, 0]));
        } else {
            diff.put_pixel(x, y, Rgb([faint, faint, faint]));
        }
    }
    Some((differing as f64 / (w as f64 * h as f64), diff))
}

/// Compares one rendered page with its reference (or rewrites the
/// reference under `VISUAL_UPDATE=1`); returns the failure, if any.
fn check_page(name: &str, actual: &GrayImage) -> Option<String> {
    let dir = reference_dir();
    let reference = dir.join(format!("{name}.png"));
    let actual_path = dir.join(format!("{name}.actual.png"));
    let diff_path = dir.join(format!("{name}.diff.png"));
    let _ = std::fs::remove_file(&actual_path);
    let _ = std::fs::remove_file(&diff_path);
    if std::env::var_os("VISUAL_UPDATE").is_some_and(|v| v == "1") {
        std::fs::create_dir_all(&dir).unwrap();
        actual.save(&reference).unwrap();
        return None;
    }
    let Ok(expected) = image::open(&reference) else {
        actual.save(&actual_path).unwrap();
        return Some(format!(
            "{name}: no reference {} (actual page: {}; VISUAL_UPDATE=1 writes it)",
            reference.display(),
            actual_path.display()
        ));
    };
    let expected = expected.to_luma8();
    let failure = match compare(actual, &expected) {
        None => format!(
            "{name}: size {:?}, reference {:?}",
            actual.dimensions(),
            expected.dimensions()
        ),
        Some((share, _)) if share <= MAX_DIFFERING => return None,
        Some((share, diff)) => {
            diff.save(&diff_path).unwrap();
            format!(
                "{name}: {:.2} % of pixels differ by more than {GREY_TOLERANCE} grey levels (at most {:.2} % may); diff: {}",
                share * 100.0,
                MAX_DIFFERING * 100.0,
                diff_path.display()
            )
        }
    };
    actual.save(&actual_path).unwrap();
    Some(format!(
        "{failure}; actual: {}; reference: {}",
        actual_path.display(),
        reference.display()
    ))
}

#[test]
fn key_pdf_pages_match_their_reference_images() {
    let dir = small_report("visual-pdf");
    let pdf = dir.join("report.pdf");
    let pages = page_count(&pdf);
    let failures: Vec<String> = PAGES
        .iter()
        .filter_map(|(name, needles)| {
            let k = page_with(&pdf, pages, needles);
            let actual = render(&pdf, k, &dir.join(format!("{name}.png")));
            check_page(name, &actual).map(|f| format!("{f} (page {k})"))
        })
        .collect();
    assert!(
        failures.is_empty(),
        "rendered pages differ from tests/integration/visual/ (a deliberate change: VISUAL_UPDATE=1, then look at the new references):\n{}",
        failures.join("\n")
    );
}

#[test]
fn the_references_stay_small() {
    let total: u64 = std::fs::read_dir(reference_dir())
        .unwrap()
        .flatten()
        .filter(|e| {
            let n = e.file_name().to_string_lossy().into_owned();
            n.ends_with(".png") && !n.ends_with(".actual.png") && !n.ends_with(".diff.png")
        })
        .map(|e| e.metadata().unwrap().len())
        .sum();
    assert!(total > 0 && total < 300_000, "{total} bytes of references");
}

#[test]
fn page_comparison_tells_a_changed_page_from_the_same_page() {
    let page = GrayImage::from_fn(200, 100, |x, _| {
        image::Luma([if x < 100 { 255 } else { 0 }])
    });
    let (same, _) = compare(&page, &page).unwrap();
    assert_eq!(same, 0.0);
    // Anti-aliasing: every pixel a little off is no difference.
    let blurred = GrayImage::from_fn(200, 100, |x, _| {
        image::Luma([if x < 100 {
            255 - GREY_TOLERANCE
        } else {
            GREY_TOLERANCE
        }])
    });
    assert_eq!(compare(&blurred, &page).unwrap().0, 0.0);
    // A 10 x 10 block of text (0.5 % of the page) is.
    let mut changed = page.clone();
    for (x, y) in (10..20).flat_map(|x| (10..20).map(move |y| (x, y))) {
        changed.put_pixel(x, y, image::Luma([0]));
    }
    let (share, diff) = compare(&changed, &page).unwrap();
    assert!(share > MAX_DIFFERING, "{share}");
    assert_eq!(diff.get_pixel(15, 15), &Rgb([220, 0, 0]));
    assert!(compare(&GrayImage::new(10, 10), &page).is_none());
}

/// Loads `html` in headless Chromium; returns the screenshot and every
/// console line Chromium logged (script errors are logged as `CONSOLE`).
pub(crate) fn chromium(html: &Path, scratch_dir: &Path) -> (RgbImage, Vec<String>) {
    let shot = scratch_dir.join("screenshot.png");
    let profile = scratch_dir.join("chromium-profile");
    let o = Command::new("chromium")
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--enable-logging=stderr",
            "--v=0",
            "--window-size=1200,2400",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(format!("--screenshot={}", shot.display()))
        .arg(format!("file://{}", html.display()))
        .output()
        .expect("chromium not found: scripts/test.sh installs it (apt-get install chromium)");
    assert!(o.status.success(), "chromium: {}", text(&o));
    let console = String::from_utf8_lossy(&o.stderr)
        .lines()
        .filter(|l| l.contains(":CONSOLE") || l.contains("Uncaught"))
        .map(str::to_string)
        .collect();
    (image::open(&shot).unwrap().to_rgb8(), console)
}

#[test]
fn html_report_renders_in_chromium_without_console_errors() {
    let dir = small_report("visual-html");
    let html = dir.join("report.html");
    let (shot, console) = chromium(&html, &dir);
    assert_eq!(shot.dimensions(), (1200, 2400));
    let inked = shot
        .pixels()
        .filter(|p| p.0.iter().any(|&c| c < 200))
        .count();
    let share = inked as f64 / (1200.0 * 2400.0);
    // Text, tables and charts: a blank or unstyled page has far less ink.
    assert!(
        share > 0.01,
        "{:.3} % of the screenshot is inked",
        share * 100.0
    );
    assert!(console.is_empty(), "console output: {console:#?}");

    // The check sees a script error: the same page with one injected.
    let broken = dir.join("broken.html");
    let page = std::fs::read_to_string(&html).unwrap();
    let probe = "<script>throw new Error('visual-probe')</script></body>";
    std::fs::write(&broken, page.replace("</body>", probe)).unwrap();
    let (_, console) = chromium(&broken, &dir);
    assert!(
        console.iter().any(|l| l.contains("visual-probe")),
        "an injected script error was not seen: {console:#?}"
    );
}
