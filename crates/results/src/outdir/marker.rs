//! The marker of a new generation: what this run wrote, for a later run.

use super::{Generation, MARKER, MARKER_HEADER, OutDirError, SIGNOFF_FILES, io_err, list_files};

impl Generation {
    /// Writes [`MARKER`] into the new generation: the entries this run
    /// wrote, then every file inside its folders. Call it after the report
    /// is written and before it is signed, so that the signature covers it
    /// (a marker edited afterwards would let a later run replace a user's
    /// file, or keep a stale one); [`Generation::commit`] writes it again,
    /// to the same bytes. The sign-off's own files are left out: they are
    /// written after it, and every run counts them as its own.
    pub fn write_marker(&self) -> Result<(), OutDirError> {
        let mut text = format!("{MARKER_HEADER}\n");
        let mut names: Vec<String> = std::fs::read_dir(&self.staging)
            .map_err(|e| io_err(&self.out, "list", &self.staging, e))?
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| {
                !self.carried.contains(n) && n != MARKER && !SIGNOFF_FILES.contains(&n.as_str())
            })
            .collect();
        names.sort();
        // Then every file written inside the folders, so that a file a
        // user saves there later is known for theirs.
        let mut inside = Vec::new();
        for n in &names {
            list_files(&self.staging.join(n), n, &mut inside)
                .map_err(|e| io_err(&self.out, "list", &self.staging.join(n), e))?;
        }
        inside.sort();
        for n in names.iter().chain(&inside) {
            text.push_str(n);
            text.push('\n');
        }
        let marker = self.staging.join(MARKER);
        crate::util::write_atomic(&marker, text.as_bytes())
            .map_err(|e| io_err(&self.out, "write", &marker, e))
    }
}
