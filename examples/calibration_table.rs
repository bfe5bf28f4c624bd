//! Prints the parameter-recovery table of docs/calibration.md:
//! `cargo run --example calibration_table`.

fn main() {
    let dir = std::env::temp_dir().join(format!("ledflicker-recovery-{}", std::process::id()));
    if let Err(e) = std::fs::create_dir_all(&dir) {
        eprintln!("error: cannot create `{}`: {e}", dir.display());
        std::process::exit(3);
    }
    let result = ledflicker::calibrate::recovery::table(&dir);
    let _ = std::fs::remove_dir_all(&dir);
    match result {
        Ok(t) => print!("{t}"),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(3);
        }
    }
}
