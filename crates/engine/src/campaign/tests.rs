use super::*;

fn env_of<'a>(vars: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
    move |k| {
        vars.iter()
            .find(|(n, _)| *n == k)
            .map(|(_, v)| v.to_string())
    }
}

#[test]
fn the_database_is_found_by_flag_then_environment_then_xdg_then_home() {
    let all = [
        (ENV, "/env/db.sqlite"),
        ("XDG_DATA_HOME", "/xdg"),
        ("HOME", "/home/u"),
    ];
    let file = |p: &str| Some(Location::File(PathBuf::from(p)));
    let default = |p: &str| Some(Location::Default(PathBuf::from(p)));
    assert_eq!(locate(None, true, &env_of(&all)), Some(Location::Off));
    assert_eq!(
        locate(Some(Path::new("x.sqlite")), false, &env_of(&all)),
        file("x.sqlite")
    );
    assert_eq!(locate(None, false, &env_of(&all)), file("/env/db.sqlite"));
    assert_eq!(
        locate(None, false, &env_of(&all[1..])),
        default("/xdg/ledflicker/results.sqlite")
    );
    // A relative XDG_DATA_HOME is ignored, as the specification says.
    let relative = [("XDG_DATA_HOME", "xdg"), ("HOME", "/home/u")];
    assert_eq!(
        locate(None, false, &env_of(&relative)),
        default("/home/u/.local/share/ledflicker/results.sqlite")
    );
    assert_eq!(locate(None, false, &env_of(&[])), None);
}

#[test]
fn an_empty_file_of_version_0_is_migrated_to_the_current_schema() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("new/results.sqlite");
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(&path, b"").unwrap();
    let db = Db::open(&path).unwrap();
    assert_eq!(db.version().unwrap(), MIGRATIONS.len());
    let tables: i64 = db
        .conn
        .query_row(
            "SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name IN ('runs', 'cases', 'rois', 'metrics', 'checks')",
            [],
            |r| r.get(0),
        )
        .unwrap();
    assert_eq!(tables, 5);
    // Opening again applies nothing more.
    drop(db);
    assert_eq!(
        Db::open(&path).unwrap().version().unwrap(),
        MIGRATIONS.len()
    );
}

/// A later version of the schema, for the framework's test: the shipped
/// steps and one more that adds a column and fills it from the old data.
const NEXT: &str = "ALTER TABLE runs ADD COLUMN camera_label TEXT; \
                    UPDATE runs SET camera_label = model || ' ' || firmware;";

#[test]
fn a_database_of_the_previous_version_keeps_its_runs_through_the_next_step() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("results.sqlite");
    let old = Db::open(&path).unwrap();
    old.conn
        .execute(
            "INSERT INTO runs (recorded_unix_s, source, date, plan_id, plan_title, plan_hash, seed, tool, backend, supplier, model, serial, firmware, signature, report_dir, results_sha256, verdict, cases_total, cases_pass, cases_fail, cases_info) \
             VALUES (0, 'plan', '2026-01-01', 'daylight', 't', 'h', 1, 'ledflicker 0', 'sim', 's', 'EX-1', '1', '1.0', 'unsigned', '/r', 'x', 'pass', 1, 1, 0, 0)",
            [],
        )
        .unwrap();
    drop(old);
    let steps: Vec<&str> = MIGRATIONS.iter().copied().chain([NEXT]).collect();
    let new = Db::open_with(&path, &steps).unwrap();
    assert_eq!(new.version().unwrap(), MIGRATIONS.len() + 1);
    let label: String = new
        .conn
        .query_row("SELECT camera_label FROM runs", [], |r| r.get(0))
        .unwrap();
    assert_eq!(label, "EX-1 1.0");
    drop(new);
    // This build's schema is older than the file's now: refused, named.
    let err = Db::open(&path).err().unwrap().to_string();
    assert!(err.contains("results database"), "{err}");
    let err = format!("{:?}", Db::open(&path).err().unwrap());
    assert!(err.contains("newer than this ledflicker's"), "{err}");
}

#[test]
fn a_failing_step_leaves_the_previous_version_whole() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("results.sqlite");
    drop(Db::open(&path).unwrap());
    let broken = "ALTER TABLE runs ADD COLUMN half TEXT; SELECT * FROM no_such_table;";
    let steps: Vec<&str> = MIGRATIONS.iter().copied().chain([broken]).collect();
    assert!(Db::open_with(&path, &steps).is_err());
    let db = Db::open(&path).unwrap();
    assert_eq!(db.version().unwrap(), MIGRATIONS.len());
    // The step's first statement was rolled back with it.
    assert!(db.conn.prepare("SELECT half FROM runs").is_err());
}

#[test]
fn files_that_are_not_results_databases_are_refused_with_a_hint() {
    let dir = tempfile::tempdir().unwrap();
    let text = dir.path().join("notes.txt");
    std::fs::write(&text, "x".repeat(4096)).unwrap();
    let e = format!("{:?}", Db::open(&text).err().unwrap());
    assert!(e.contains("not an SQLite database"), "{e}");
    let other = dir.path().join("other.sqlite");
    Connection::open(&other)
        .unwrap()
        .execute_batch("CREATE TABLE t (x)")
        .unwrap();
    let e = format!("{:?}", Db::open(&other).err().unwrap());
    assert!(e.contains("not a ledflicker results database"), "{e}");
    let e = Db::open_existing(&dir.path().join("missing.sqlite"))
        .err()
        .unwrap();
    assert!(e.is_usage_error());
}
