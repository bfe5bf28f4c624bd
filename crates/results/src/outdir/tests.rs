//! Tests of report directories: generations, carrying the user's entries
//! over, refusals.

use super::*;

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ledflicker-outdir-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn write_generation(out: &Path, files: &[(&str, &str)]) {
    let g = Generation::begin(out).unwrap();
    for (name, text) in files {
        let p = g.path().join(name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, text).unwrap();
    }
    g.commit().unwrap();
}

#[test]
fn a_foreign_directory_is_refused_and_left_alone() {
    let root = scratch("foreign");
    let out = root.join("captures");
    std::fs::create_dir_all(out.join("frames")).unwrap();
    std::fs::write(out.join("frames/0001.png"), "mine").unwrap();
    assert_refused_and_kept(&root, &out, "frames/0001.png", "holds no ledflicker report");
}

/// `begin` on `out` is refused with a usage error saying `says`; the
/// user's file `kept` (holding "mine") is as it was, and nothing is
/// left beside `out` in `root`.
fn assert_refused_and_kept(root: &Path, out: &Path, kept: &str, says: &str) {
    let err = Generation::begin(out).unwrap_err();
    assert!(err.is_usage_error(), "{err}");
    assert!(err.to_string().contains(says), "{err}");
    assert_eq!(std::fs::read_to_string(out.join(kept)).unwrap(), "mine");
    assert_eq!(
        std::fs::read_dir(root).unwrap().count(),
        1,
        "no staging left behind"
    );
}

#[test]
fn a_users_entry_under_a_name_the_report_writes_is_refused_and_kept() {
    let root = scratch("user-frames");
    let out = root.join("report");
    // The last run wrote no frames/; the user then made one.
    write_generation(&out, &[("results.json", "1"), ("traces/a.csv", "a")]);
    std::fs::create_dir_all(out.join("frames")).unwrap();
    std::fs::write(out.join("frames/bench-photo.jpg"), "mine").unwrap();
    assert_refused_and_kept(
        &root,
        &out,
        "frames/bench-photo.jpg",
        "holds `frames`, which ledflicker did not write there",
    );
    // Moved out of the way, the run goes ahead.
    std::fs::rename(out.join("frames"), root.join("photos")).unwrap();
    write_generation(&out, &[("results.json", "2")]);
    assert_eq!(
        std::fs::read_to_string(out.join("results.json")).unwrap(),
        "2"
    );
}

#[test]
fn a_new_generation_replaces_ours_and_keeps_the_users_files() {
    let root = scratch("regen");
    let out = root.join("report");
    write_generation(
        &out,
        &[
            ("results.json", "1"),
            ("traces/a.csv", "a"),
            ("traces/b.csv", "b"),
        ],
    );
    std::fs::write(out.join("notes.txt"), "user notes").unwrap();
    write_generation(&out, &[("results.json", "2"), ("traces/a.csv", "a2")]);
    assert_eq!(
        std::fs::read_to_string(out.join("results.json")).unwrap(),
        "2"
    );
    assert!(
        !out.join("traces/b.csv").exists(),
        "old generation's files are gone"
    );
    assert_eq!(
        std::fs::read_to_string(out.join("notes.txt")).unwrap(),
        "user notes"
    );
    let marker = std::fs::read_to_string(out.join(MARKER)).unwrap();
    assert!(
        marker.contains("\nresults.json\n") && !marker.contains("notes.txt"),
        "{marker}"
    );
    let left: Vec<_> = std::fs::read_dir(&root)
        .unwrap()
        .flatten()
        .map(|e| e.file_name())
        .collect();
    assert_eq!(left.len(), 1, "only the report is left: {left:?}");
}

/// Writes `files` into a generation begun on `out`, calls `during`
/// (what a user does while the run goes on), then commits.
fn run_with(
    out: &Path,
    files: &[(&str, &str)],
    during: impl FnOnce(),
) -> Result<Committed, OutDirError> {
    let g = Generation::begin(out).unwrap();
    for (name, text) in files {
        let p = g.path().join(name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, text).unwrap();
    }
    during();
    g.commit()
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap()
}

#[test]
fn what_a_user_saves_edits_or_deletes_during_a_run_is_as_they_left_it() {
    let root = scratch("during");
    let out = root.join("report");
    write_generation(&out, &[("results.json", "1")]);
    std::fs::write(out.join("notes.txt"), "first draft").unwrap();
    std::fs::write(out.join("scratch.txt"), "to delete").unwrap();
    std::fs::create_dir_all(out.join("lab")).unwrap();
    std::fs::write(out.join("lab/setup.txt"), "bench 3").unwrap();
    run_with(&out, &[("results.json", "2")], || {
        // A new file, an editor's save (a temporary file renamed over
        // the original), a file added to a folder, and a deletion.
        std::fs::write(out.join("photo.txt"), "new").unwrap();
        std::fs::write(out.join(".notes.txt.swp"), "second draft").unwrap();
        std::fs::rename(out.join(".notes.txt.swp"), out.join("notes.txt")).unwrap();
        std::fs::write(out.join("lab/wiring.txt"), "cable B").unwrap();
        std::fs::remove_file(out.join("scratch.txt")).unwrap();
    })
    .unwrap();
    assert_eq!(read(&out.join("results.json")), "2");
    assert_eq!(read(&out.join("photo.txt")), "new");
    assert_eq!(read(&out.join("notes.txt")), "second draft");
    assert_eq!(read(&out.join("lab/setup.txt")), "bench 3");
    assert_eq!(read(&out.join("lab/wiring.txt")), "cable B");
    assert!(!out.join("scratch.txt").exists());
    assert!(!read(&out.join(MARKER)).contains("photo.txt"));
    // An empty directory given as --out, filled by the user meanwhile.
    let fresh = root.join("fresh");
    std::fs::create_dir_all(&fresh).unwrap();
    run_with(&fresh, &[("results.json", "1")], || {
        std::fs::write(fresh.join("readme.txt"), "mine").unwrap();
    })
    .unwrap();
    assert_eq!(read(&fresh.join("readme.txt")), "mine");
    let left: Vec<_> = std::fs::read_dir(&root).unwrap().flatten().collect();
    assert_eq!(left.len(), 2, "only the reports are left: {left:?}");
}

#[test]
fn a_users_entry_made_during_the_run_under_a_name_the_run_writes_stops_the_swap() {
    let root = scratch("during-clash");
    let out = root.join("report");
    write_generation(&out, &[("results.json", "1")]);
    let err = run_with(
        &out,
        &[("results.json", "2"), ("frames/a.png", "x")],
        || {
            std::fs::create_dir_all(out.join("frames")).unwrap();
            std::fs::write(out.join("frames/holiday.png"), "mine").unwrap();
        },
    )
    .unwrap_err();
    assert!(err.is_usage_error(), "{err}");
    let text = err.to_string();
    assert!(
        text.contains("`frames`") && text.contains("kept at"),
        "{text}"
    );
    // Nothing of the user's or of the old report changed, and the new
    // report waits beside it.
    assert_eq!(read(&out.join("frames/holiday.png")), "mine");
    assert_eq!(read(&out.join("results.json")), "1");
    let kept = root.join(format!("report.new-{}", std::process::id()));
    assert_eq!(read(&kept.join("results.json")), "2");
    assert!(text.contains(&kept.display().to_string()), "{text}");
}

#[test]
fn an_edit_between_the_last_carry_and_the_swap_keeps_the_earlier_generation() {
    let root = scratch("during-race");
    let out = root.join("report");
    write_generation(&out, &[("results.json", "1")]);
    std::fs::write(out.join("notes.txt"), "v1").unwrap();
    let mut g = Generation::begin(&out).unwrap();
    std::fs::write(g.path().join("results.json"), "2").unwrap();
    g.carry_foreign_again().unwrap();
    // Saved in the instant before the swap.
    std::fs::write(out.join(".n.tmp"), "v2").unwrap();
    std::fs::rename(out.join(".n.tmp"), out.join("notes.txt")).unwrap();
    let done = g.swap_in().unwrap();
    let (kept, names) = done.kept.clone().unwrap();
    assert_eq!(names, ["notes.txt"]);
    assert_eq!(read(&kept.join("notes.txt")), "v2");
    assert_eq!(read(&out.join("results.json")), "2");
    assert!(done.warning().unwrap().contains("`notes.txt`"));
}

#[test]
fn a_staging_directory_of_a_dead_process_is_removed_and_an_old_report_restored() {
    let root = scratch("stale");
    let out = root.join("report");
    write_generation(&out, &[("results.json", "old")]);
    // A run killed between the two renames of a non-atomic swap.
    let dead = u32::MAX - 1;
    let old = root.join(format!(".report.ledflicker-old-{dead}"));
    std::fs::rename(&out, &old).unwrap();
    let new = root.join(format!(".report.ledflicker-new-{dead}"));
    std::fs::create_dir_all(new.join("traces")).unwrap();
    assert_eq!(clean_stale(&out).unwrap(), 1);
    assert_eq!(
        std::fs::read_to_string(out.join("results.json")).unwrap(),
        "old"
    );
    assert!(!new.exists() && !old.exists());
}

#[test]
fn an_uncommitted_generation_leaves_the_old_report_untouched() {
    let root = scratch("abort");
    let out = root.join("report");
    write_generation(&out, &[("results.json", "old")]);
    let g = Generation::begin(&out).unwrap();
    std::fs::write(g.path().join("results.json"), "half").unwrap();
    drop(g);
    assert_eq!(
        std::fs::read_to_string(out.join("results.json")).unwrap(),
        "old"
    );
    assert_eq!(std::fs::read_dir(&root).unwrap().count(), 1);
}

#[test]
fn a_fifo_at_the_marker_or_results_is_refused_not_waited_on() {
    for name in [MARKER, "results.json"] {
        let root = scratch(&format!("fifo{}", name.len()));
        let out = root.join("report");
        std::fs::create_dir_all(&out).unwrap();
        let c =
            std::ffi::CString::new(out.join(name).into_os_string().into_encoded_bytes()).unwrap();
        // SAFETY: a NUL-terminated path that lives across the call.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let err = Generation::begin(&out).unwrap_err();
        let text = err.to_string();
        assert!(err.is_usage_error() && text.contains("FIFO"), "{text}");
        assert!(text.contains(name), "{text}");
    }
}

#[test]
fn a_name_too_long_for_the_generations_beside_it_is_a_usage_error() {
    let root = scratch("long");
    let out = root.join("r".repeat(300));
    let err = Generation::begin(&out).unwrap_err();
    assert!(err.is_usage_error(), "{err}");
    assert!(err.to_string().contains("300 bytes"), "{err}");
    let fits = root.join("r".repeat(200));
    write_generation(&fits, &[("results.json", "1")]);
    assert_eq!(read(&fits.join("results.json")), "1");
}

#[test]
fn a_file_in_place_of_the_directory_is_refused() {
    let root = scratch("file");
    let out = root.join("report");
    std::fs::write(&out, "x").unwrap();
    let err = Generation::begin(&out).unwrap_err();
    assert!(
        err.is_usage_error() && err.to_string().contains("not a directory"),
        "{err}"
    );
}

#[test]
fn a_report_folder_swapped_for_a_link_during_the_run_is_not_swapped_out() {
    let root = scratch("swapped-link");
    let out = root.join("report");
    write_generation(&out, &[("results.json", "1"), ("traces/a.csv", "a")]);
    let users = root.join("users-folder");
    std::fs::create_dir_all(users.join("traces")).unwrap();
    std::fs::write(users.join("thesis.txt"), "mine").unwrap();
    std::fs::write(users.join("traces/bench.csv"), "mine").unwrap();

    let g = Generation::begin(&out).unwrap();
    std::fs::write(g.path().join("results.json"), "2").unwrap();
    // During the run the report folder is replaced by a link to the user's.
    std::fs::rename(&out, root.join("moved-away")).unwrap();
    std::os::unix::fs::symlink(&users, &out).unwrap();
    let err = g.commit().unwrap_err();
    assert!(
        err.to_string().contains("was replaced during the run"),
        "{err}"
    );
    assert!(err.to_string().contains("symbolic link"), "{err}");

    // The link and the user's folder are as they were; the new report is
    // kept aside and holds none of the user's files.
    assert!(
        std::fs::symlink_metadata(&out)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert_eq!(read(&users.join("thesis.txt")), "mine");
    assert_eq!(read(&users.join("traces/bench.csv")), "mine");
    let kept: Vec<PathBuf> = std::fs::read_dir(&root)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.to_string_lossy().contains("report.new-"))
        .collect();
    assert_eq!(kept.len(), 1, "{kept:?}");
    assert_eq!(read(&kept[0].join("results.json")), "2");
    assert!(!kept[0].join("thesis.txt").exists());
}
