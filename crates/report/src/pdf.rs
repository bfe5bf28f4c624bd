//! PDF report: a minijinja template (templates/report.typ.j2) renders Typst
//! markup, which typst 0.15 lays out and typst-pdf writes as PDF.
//!
//! Last stage of the pipeline, next to [`super::html`]. The Typst `World`
//! below is deliberately minimal: every file comes from memory (the
//! generated markup, the chart SVGs, the fonts compiled into the binary),
//! nothing is read from disk or the network, and `today()` is the report
//! date, so the same inputs give byte-identical PDFs. The chart SVGs are
//! simplified for Typst first ([`shapes`]): the same picture in fewer and
//! cheaper shapes.

mod shapes;

use std::collections::BTreeMap;
use std::sync::{LazyLock, OnceLock};

use minijinja::value::{Serde, Value};
use minijinja::{Environment, UndefinedBehavior};
use typst::diag::{FileError, FileResult, SourceDiagnostic};
use typst::foundations::{Bytes, Datetime};
use typst::syntax::{FileId, RootedPath, Source, VirtualPath, VirtualRoot};
use typst::text::{Font, FontBook};
use typst::utils::LazyHash;
use typst::{Library, LibraryExt, World, WorldExt};
use typst_layout::PagedDocument;

use super::ReportError;
use super::document::{ChartJobs, Document, ViewJobs};

const TEMPLATE: &str = include_str!("../../../templates/report.typ.j2");
const TEMPLATE_NAME: &str = "report.typ.j2";

/// DejaVu Sans (regular and bold), shipped in assets/fonts with its licence.
/// Charts name this family; typst's bundled fonts have no sans-serif face.
const DEJAVU_SANS: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");
const DEJAVU_SANS_BOLD: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans-Bold.ttf");

/// Fonts and font book, built once per process.
struct Fonts {
    book: LazyHash<FontBook>,
    fonts: Vec<Font>,
}

static FONTS: LazyLock<Fonts> = LazyLock::new(|| {
    let mut fonts = Vec::new();
    for data in [DEJAVU_SANS, DEJAVU_SANS_BOLD]
        .into_iter()
        .chain(typst_assets::fonts())
    {
        fonts.extend(Font::iter(Bytes::new(data)));
    }
    Fonts {
        book: LazyHash::new(FontBook::from_fonts(&fonts)),
        fonts,
    }
});

static LIBRARY: LazyLock<LazyHash<Library>> =
    LazyLock::new(|| LazyHash::new(Library::builder().build()));

/// The in-memory world one report is compiled in.
struct ReportWorld<'a> {
    main: FileId,
    source: Source,
    /// Virtual path (no leading slash) -> file.
    files: BTreeMap<&'a str, WorldFile>,
    /// Where the charts and frame views come from.
    pictures: Pictures<'a>,
    today: Option<Datetime>,
    /// The report profile's logo: its virtual path and bytes.
    logo: Option<(String, Bytes)>,
}

/// A file of the world: a frame view as it is, or a chart, simplified for
/// Typst ([`shapes::simplify`]); either loaded when Typst first reads it.
/// Typst reads them from the page runs it lays out in parallel, and only
/// those the report shows.
struct WorldFile {
    chart: bool,
    bytes: OnceLock<Result<Bytes, String>>,
}

impl WorldFile {
    fn new(chart: bool) -> Self {
        WorldFile {
            chart,
            bytes: OnceLock::new(),
        }
    }
}

/// The charts and frame views of a report: drawn already (a
/// [`Document`]'s), or drawn when Typst first reads them (jobs).
#[derive(Clone, Copy)]
pub enum Pictures<'a> {
    /// The document's charts and images.
    Drawn(&'a Document),
    /// Drawn on first use, by whichever thread asks first.
    Jobs(&'a ChartJobs<'a>, &'a ViewJobs<'a>),
    /// Charts of a document other than a run's report (the comparison
    /// report), by path; it has no frame views.
    Svgs(&'a BTreeMap<String, String>),
}

impl Pictures<'_> {
    /// The file at `path` as Typst reads it.
    fn load(self, path: &str, chart: bool) -> Result<Bytes, String> {
        let missing = || format!("no picture `{path}`");
        if chart {
            let svg = match self {
                Pictures::Drawn(doc) => doc.charts.get(path).map(String::as_str),
                Pictures::Jobs(charts, _) => match charts.get(path) {
                    Some(Err(e)) => return Err(e.to_string()),
                    Some(Ok(svg)) => Some(svg.as_str()),
                    None => None,
                },
                Pictures::Svgs(svgs) => svgs.get(path).map(String::as_str),
            };
            Ok(Bytes::from_string(shapes::simplify(
                svg.ok_or_else(missing)?,
            )))
        } else {
            let png = match self {
                Pictures::Drawn(doc) => doc.images.get(path),
                Pictures::Jobs(_, views) => match views.get(path) {
                    Some(Err(e)) => return Err(e.to_string()),
                    Some(Ok(png)) => Some(png),
                    None => None,
                },
                Pictures::Svgs(_) => None,
            };
            Ok(Bytes::new(png.ok_or_else(missing)?.clone()))
        }
    }
}

fn file_id(path: &str) -> Result<FileId, ReportError> {
    let vpath = VirtualPath::new(path).map_err(|e| ReportError::Pdf {
        message: format!("bad virtual path `{path}`: {e:?}"),
    })?;
    Ok(RootedPath::new(VirtualRoot::Project, vpath).intern())
}

impl World for ReportWorld<'_> {
    fn library(&self) -> &LazyHash<Library> {
        &LIBRARY
    }

    fn book(&self) -> &LazyHash<FontBook> {
        &FONTS.book
    }

    fn main(&self) -> FileId {
        self.main
    }

    fn source(&self, id: FileId) -> FileResult<Source> {
        if id == self.main {
            Ok(self.source.clone())
        } else {
            Err(FileError::NotSource)
        }
    }

    fn file(&self, id: FileId) -> FileResult<Bytes> {
        let path = id.vpath().get_without_slash();
        if let Some((logo, bytes)) = &self.logo
            && logo == path
        {
            return Ok(bytes.clone());
        }
        let file = self
            .files
            .get(path)
            .ok_or_else(|| FileError::NotFound(path.into()))?;
        file.bytes
            .get_or_init(|| self.pictures.load(path, file.chart))
            .clone()
            .map_err(|e| FileError::Other(Some(e.into())))
    }

    fn font(&self, index: usize) -> Option<Font> {
        FONTS.fonts.get(index).cloned()
    }

    fn today(&self, _offset: Option<typst::foundations::Duration>) -> Option<Datetime> {
        self.today
    }
}

/// Turns a value into a Typst string literal, `"..."`, escaping what Typst
/// would otherwise read as markup or an escape. Text with Markdown code
/// spans (`hdr3-1080p30`) becomes a code block that joins the prose and
/// `raw(..)` pieces, `{"camera "; raw("hdr3-1080p30")}`: content that
/// stands where the literal would, with the code set as code and no
/// backtick left.
pub(crate) fn typst_str(value: &Value) -> String {
    let text = match value.as_str() {
        Some(s) => s.to_string(),
        None if value.is_none() || value.is_undefined() => String::new(),
        None => value.to_string(),
    };
    if !text.contains('`') {
        return typst_literal(&text);
    }
    let pieces: Vec<String> = super::html::code_spans(&text)
        .into_iter()
        .map(|(code, piece)| {
            if code {
                format!("raw({})", typst_literal(piece))
            } else {
                typst_literal(piece)
            }
        })
        .collect();
    format!("{{{}}}", pieces.join("; "))
}

/// `text` as a Typst string literal.
fn typst_literal(text: &str) -> String {
    let mut out = String::with_capacity(text.len() + 2);
    out.push('"');
    for c in text.chars() {
        match c {
            '\\' => out.push_str("\\\\"),
            '"' => out.push_str("\\\""),
            '\n' => out.push_str("\\n"),
            '\r' => {}
            '\t' => out.push_str("\\t"),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// Renders the Typst markup of the report (the template's output).
pub fn render_markup(doc: &Document) -> Result<String, ReportError> {
    let mut env = Environment::new();
    env.set_undefined_behavior(UndefinedBehavior::Strict);
    super::html::add_templates(&mut env, &[(TEMPLATE_NAME, TEMPLATE)], &doc.look)?;
    let template_error =
        |e: minijinja::Error| super::html::template_error(&e, TEMPLATE_NAME, &doc.look);
    env.add_filter("t", |v: Value| typst_str(&v));
    env.add_filter("metric", |id: &str| {
        crate::model::human_name(id).to_string()
    });
    env.add_filter("metric_short", |id: &str| {
        crate::model::short_name(id).to_string()
    });
    env.add_filter("num", |v: Serde<Option<f64>>, digits: Option<usize>| {
        super::html::num(v.0, digits)
    });
    // Every picture goes in by its virtual path in the world.
    let picture = |path: &str| Value::from(path);
    let look = doc.look_context(|path, _| Value::from(path));
    let context = minijinja::context! {
        appendix_pages => appendix_page_values(doc),
        ..super::context::shared(doc, &picture, look)?
    };
    let template = env.get_template(TEMPLATE_NAME).map_err(template_error)?;
    template.render(context).map_err(template_error)
}

/// The longest case id and ROI name that Appendix A's table surely sets on
/// one line (its case and ROI columns are as wide as their widest entry,
/// unless the table is too wide for the page).
const APPENDIX_ONE_LINE_ID: usize = 28;
const APPENDIX_ONE_LINE_ROI: usize = 16;

/// Appendix A page by page for the template: `cases` (indices into the
/// cases the templates see, the listed ones, [`Document::json`]) and
/// `fixed`, whether every row is one line, so that the table can be given
/// its row heights instead of measuring each row's cells first (about a
/// third of the table's layout).
fn appendix_page_values(doc: &Document) -> Vec<Value> {
    let listing = doc.listing();
    let listed: Vec<_> = doc
        .results
        .cases
        .resident()
        .filter(|c| listing.listed.contains(&c.id))
        .collect();
    appendix_pages(listed.iter().map(|c| c.rois.len()))
        .into_iter()
        .map(|page| {
            let fixed = page.iter().all(|&k| {
                let c = listed[k];
                c.id.chars().count() <= APPENDIX_ONE_LINE_ID
                    && c.rois
                        .iter()
                        .all(|r| r.name.chars().count() <= APPENDIX_ONE_LINE_ROI)
            });
            minijinja::context! { cases => page, fixed => fixed }
        })
        .collect()
}

/// Rows of Appendix A's table (7 pt text, the smallest the report prints,
/// 3 pt inset: about 12 pt a row) that one page holds below the table's
/// header, with room to spare: a full page takes 59.
const APPENDIX_PAGE_ROWS: f64 = 54.0;
/// The same on the appendix's first page, below its heading and lead text.
const APPENDIX_FIRST_PAGE_ROWS: f64 = 48.0;
/// A case of one ROI takes one row, as tall as its verdict badge.
const APPENDIX_BADGE_ROWS: f64 = 1.4;

/// Appendix A's cases page by page (indices into the cases, in order),
/// given each case's ROI count: one table a page, so that Typst lays out
/// the pages in parallel (a page break starts a new page run) instead of
/// one long table at the end of the document. A case is never split; a
/// case too large for a page has a table of its own, which breaks across
/// pages as any table does.
fn appendix_pages(rois_per_case: impl Iterator<Item = usize>) -> Vec<Vec<usize>> {
    let mut pages: Vec<Vec<usize>> = Vec::new();
    let (mut page, mut used) = (Vec::new(), 0.0);
    for (i, rois) in rois_per_case.enumerate() {
        let rows = (rois as f64).max(APPENDIX_BADGE_ROWS);
        let room = if pages.is_empty() {
            APPENDIX_FIRST_PAGE_ROWS
        } else {
            APPENDIX_PAGE_ROWS
        };
        if !page.is_empty() && used + rows > room {
            pages.push(std::mem::take(&mut page));
            used = 0.0;
        }
        page.push(i);
        used += rows;
    }
    if !page.is_empty() {
        pages.push(page);
    }
    pages
}

fn diagnostics(what: &str, diags: &[SourceDiagnostic], world: &ReportWorld<'_>) -> ReportError {
    let mut message = format!("{what}:");
    for d in diags {
        message.push_str("\n  - ");
        message.push_str(&d.message);
        if d.span.id() == Some(world.main)
            && let Some(range) = world.range(d.span)
        {
            let line = world.source.text()[..range.start].matches('\n').count() + 1;
            message.push_str(&format!(" (generated markup, line {line})"));
        }
        for hint in &d.hints {
            message.push_str("\n    hint: ");
            message.push_str(&hint.v);
        }
    }
    ReportError::Pdf { message }
}

fn parse_date(date: &str) -> Option<Datetime> {
    let mut parts = date.split('-');
    let y = parts.next()?.parse().ok()?;
    let m = parts.next()?.parse().ok()?;
    let d = parts.next()?.parse().ok()?;
    Datetime::from_ymd(y, m, d)
}

/// Renders report.pdf. Returns the PDF bytes and its page count.
pub fn render(doc: &Document) -> Result<(Vec<u8>, usize), ReportError> {
    render_with(doc, Pictures::Drawn(doc))
}

/// [`render`] with the charts and frame views from `pictures`:
/// `doc.charts` and `doc.images` give only their paths.
pub fn render_with(
    doc: &Document,
    pictures: Pictures<'_>,
) -> Result<(Vec<u8>, usize), ReportError> {
    let markup = {
        let _t = crate::timings::span("pdf: markup");
        render_markup(doc)?
    };
    let main = file_id("report.typ")?;
    let source = Source::new(main, markup);
    let files = doc
        .charts
        .keys()
        .map(|path| (path.as_str(), WorldFile::new(true)))
        .chain(
            doc.images
                .keys()
                .map(|path| (path.as_str(), WorldFile::new(false))),
        )
        .collect();
    let world = ReportWorld {
        main,
        source,
        files,
        pictures,
        today: parse_date(doc.date()),
        logo: doc
            .look
            .logo
            .as_ref()
            .map(|(path, bytes)| (path.clone(), Bytes::new(bytes.clone()))),
    };
    lay_out(&world, format!("ledflicker-{}", doc.results.plan.id))
}

/// Lays out the world's main file and writes it as PDF; `ident` is the
/// PDF's stable identifier (the same inputs give the same bytes).
fn lay_out(world: &ReportWorld<'_>, ident: String) -> Result<(Vec<u8>, usize), ReportError> {
    let compiled = {
        let _t = crate::timings::span("pdf: layout");
        typst::compile::<PagedDocument>(world)
    };
    let document = compiled
        .output
        .map_err(|errors| diagnostics("typst could not lay out the report", &errors, world))?;
    // Typst keeps every memoised layout result for a later compile of the
    // same world; the report is laid out once, so the cache (the larger
    // part of the PDF stage's memory) is freed before the PDF is written
    // and the next stages allocate their own.
    typst::comemo::evict(0);
    let options = typst_pdf::PdfOptions {
        // A stable identifier: the same report gives the same PDF bytes.
        ident: typst::foundations::Smart::Custom(ident),
        ..typst_pdf::PdfOptions::default()
    };
    let mut bytes = {
        let _t = crate::timings::span("pdf: write");
        typst_pdf::pdf(&document, &options)
            .map_err(|errors| diagnostics("typst could not write the PDF", &errors, world))?
    };
    blank_suspects_false(&mut bytes);
    Ok((bytes, document.pages().len()))
}

/// Lays out `markup` (a whole Typst document) with the charts `svgs` (by
/// the paths the markup names) in the report's fonts, dated `date`
/// (`YYYY-MM-DD`): the PDF of a document other than a run's report.
pub fn render_standalone(
    markup: String,
    svgs: &BTreeMap<String, String>,
    date: &str,
    ident: &str,
) -> Result<(Vec<u8>, usize), ReportError> {
    let main = file_id("document.typ")?;
    let world = ReportWorld {
        main,
        source: Source::new(main, markup),
        files: svgs
            .keys()
            .map(|path| (path.as_str(), WorldFile::new(true)))
            .collect(),
        pictures: Pictures::Svgs(svgs),
        today: parse_date(date),
        logo: None,
    };
    lay_out(&world, ident.to_string())
}

/// Overwrites the catalog's `/Suspects false` (in `/MarkInfo`) with spaces.
///
/// The entry is valid PDF and states the default, but poppler (pdfinfo,
/// pdftotext, pdfsig) reports every such file with "Syntax Error: Suspects
/// object is wrong type (boolean)". Spaces of the same length keep every
/// byte offset, so the cross-reference table stays exact.
fn blank_suspects_false(pdf: &mut [u8]) {
    const ENTRY: &[u8] = b"/Suspects false";
    let Some(mark) = find(pdf, b"/MarkInfo") else {
        return;
    };
    // Only inside the MarkInfo dictionary, which closes with `>>`.
    let end = find(&pdf[mark..], b">>").map_or(pdf.len(), |e| mark + e);
    if let Some(at) = find(&pdf[mark..end], ENTRY) {
        pdf[mark + at..mark + at + ENTRY.len()].fill(b' ');
    }
}

fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).position(|w| w == needle)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suspects_false_is_blanked_in_place_and_only_in_mark_info() {
        let mut pdf =
            b"<< /Suspects false >> 1 0 obj << /MarkInfo << /Marked true /Suspects false >> >>"
                .to_vec();
        let len = pdf.len();
        blank_suspects_false(&mut pdf);
        assert_eq!(pdf.len(), len);
        let text = String::from_utf8(pdf).unwrap();
        assert!(text.starts_with("<< /Suspects false >>"), "{text}");
        assert!(
            text.ends_with("/Marked true                 >> >>"),
            "{text}"
        );
    }

    #[test]
    fn appendix_pages_fill_each_page_and_never_split_a_case() {
        // Daylight: 35 cases of 2 ROIs, 24 under the heading, 11 after.
        let pages = appendix_pages(std::iter::repeat_n(2, 35));
        assert_eq!(pages.iter().map(Vec::len).collect::<Vec<_>>(), [24, 11]);
        assert_eq!(pages.concat(), (0..35).collect::<Vec<_>>());
        // One ROI each: badge rows, 34 and 38 a page.
        let pages = appendix_pages(std::iter::repeat_n(1, 100));
        assert_eq!(pages.iter().map(Vec::len).collect::<Vec<_>>(), [34, 38, 28]);
        // A P2020 chart of 36 patches: one case a page; a case larger than
        // a page stands alone.
        let pages = appendix_pages([36, 36, 80, 3, 0].into_iter());
        assert_eq!(pages, [vec![0], vec![1], vec![2], vec![3, 4]]);
        assert!(appendix_pages(std::iter::empty()).is_empty());
    }

    #[test]
    fn appendix_rows_get_their_heights_only_where_every_row_is_one_line() {
        let (results, model) = super::super::document::small_run();
        let mut doc = Document::build(&model, &results, "2026-01-01", Vec::new()).unwrap();
        let rows = |doc: &Document| {
            let markup = render_markup(doc).unwrap();
            markup.matches("rows: (auto").count()
        };
        let pages = appendix_pages(doc.results.cases.iter().map(|c| c.rois.len())).len();
        assert!(pages >= 1);
        assert_eq!(rows(&doc), pages, "short ids: every page's rows are given");
        // A case id that may wrap: its page's rows are measured.
        std::sync::Arc::make_mut(&mut doc.results).cases.to_mut()[0].id =
            "a-case-id-long-enough-to-wrap-in-its-column".to_string();
        assert_eq!(rows(&doc), pages - 1);
    }

    /// Smallest `font-size` of an SVG and its width, pixels.
    fn smallest_font(svg: &str) -> (f64, f64) {
        let number = |after: &str, from: &str| -> f64 {
            let v = from.split(after).nth(1).unwrap();
            v.split('"').next().unwrap().parse().unwrap()
        };
        let width = number("width=\"", svg.split("<svg").nth(1).unwrap());
        let smallest = svg
            .split("font-size=\"")
            .skip(1)
            .map(|v| v.split('"').next().unwrap().parse::<f64>().unwrap())
            .fold(f64::INFINITY, f64::min);
        (smallest, width)
    }

    #[test]
    fn every_chart_prints_its_text_at_7_pt_or_more() {
        use crate::charts::{MIN_TEXT_PT, PDF_TEXT_WIDTH_PT};
        let (results, model) = super::super::document::small_run();
        let mut doc = Document::build(&model, &results, "2026-01-01", Vec::new()).unwrap();
        // Every case a page, so every kind of chart is printed.
        std::sync::Arc::make_mut(&mut doc.results)
            .report
            .as_mut()
            .unwrap()
            .detail = "full".to_string();
        let markup = render_markup(&doc).unwrap();
        let mut kinds = std::collections::BTreeSet::new();
        // The charts as the markup places them: `image("charts/..", width: N%)`.
        for part in markup.split("image(\"charts/").skip(1) {
            let (name, rest) = part.split_once('"').unwrap();
            let percent: f64 = rest
                .strip_prefix(", width: ")
                .and_then(|r| r.split_once('%'))
                .map(|(n, _)| n.parse().unwrap())
                .unwrap_or_else(|| panic!("charts/{name}: no width in the markup"));
            let svg = &doc.charts[&format!("charts/{name}")];
            let (px, width_px) = smallest_font(svg);
            let pt = px * PDF_TEXT_WIDTH_PT * percent / 100.0 / width_px;
            assert!(
                pt >= MIN_TEXT_PT,
                "charts/{name}: {px} px text on {width_px} px printed at {percent} % is {pt:.2} pt"
            );
            kinds.insert(name.split(['-', '.']).next().unwrap().to_string());
        }
        for kind in ["trace", "zoom", "matrix", "finemap", "advice"] {
            assert!(kinds.contains(kind), "no {kind} chart printed: {kinds:?}");
        }
    }

    #[test]
    fn code_spans_become_raw_and_no_backtick_reaches_the_markup() {
        let markup = typst_str(&Value::from("camera `hdr3-1080p30` (\"a\") `b`"));
        assert_eq!(
            markup,
            "{\"camera \"; raw(\"hdr3-1080p30\"); \" (\\\"a\\\") \"; raw(\"b\")}"
        );
        // An unpaired backtick is dropped; the rest stays prose.
        assert_eq!(typst_str(&Value::from("a ` b")), "{\"a \"; \" b\"}");
        // The whole report, with a note full of code spans, lays out.
        let (results, mut model) = super::super::document::small_run();
        model
            .notes
            .push("capture `x.mp4` read with `ffmpeg`".to_string());
        let doc = Document::build(&model, &results, "2026-01-01", Vec::new()).unwrap();
        let markup = render_markup(&doc).unwrap();
        assert!(markup.contains("raw(\"x.mp4\")"), "the note's code is raw");
        assert!(render(&doc).is_ok());
    }

    #[test]
    fn typst_strings_escape_quotes_backslashes_and_newlines() {
        assert_eq!(
            typst_str(&Value::from("a \"b\" \\ #c_*<d>\n")),
            "\"a \\\"b\\\" \\\\ #c_*<d>\\n\""
        );
        assert_eq!(typst_str(&Value::from(())), "\"\"");
        assert_eq!(typst_str(&Value::from(3)), "\"3\"");
    }
}
