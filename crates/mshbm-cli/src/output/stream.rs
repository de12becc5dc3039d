//! CSV files written while a run goes on (`frf`'s points, `simulate`'s steps): rows go to
//! the temporary file of an [`AtomicFile`] (visible there while the run goes on), and when
//! the run ends — completely, early, or interrupted — a final comment line says how, and
//! the file is renamed into place:
//!
//! `# finished: 1209 points, every branch complete`,
//! `# incomplete: interrupted by SIGINT after 57 points`,
//! `# incomplete: branch H = 3 stopped: <reason>`.
//!
//! Readers skip lines starting with `#`. A write error names the file and is returned at
//! once, so the caller stops the run.

use std::path::Path;

use anyhow::Result;

use super::atomic::AtomicFile;
use super::finite::check_csv_line;
use super::plan::OutputKind;

/// A CSV file streamed row by row, committed with a status line.
pub struct StreamedCsv {
    file: AtomicFile,
    header: String,
    rows: u64,
    /// Flush after every row (slow producers, so that the temporary file shows progress).
    flush_rows: bool,
}

impl StreamedCsv {
    /// Create the temporary file of `path` and write `header`.
    pub fn create(path: &Path, header: &str, flush_rows: bool) -> Result<Self> {
        super::interrupt::streaming();
        let mut file = AtomicFile::create(path, OutputKind::Data)?;
        file.write_all(header.as_bytes())?;
        file.write_all(b"\n")?;
        if flush_rows {
            file.flush()?;
        }
        Ok(StreamedCsv {
            file,
            header: header.to_string(),
            rows: 0,
            flush_rows,
        })
    }

    /// The path the user gave.
    pub fn path(&self) -> &Path {
        self.file.path()
    }

    /// Data rows written so far.
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// Append one row (no newline); refused when it holds a NaN or an infinity.
    pub fn row(&mut self, line: &str) -> Result<()> {
        check_csv_line(self.file.path(), &self.header, self.rows as usize + 1, line)?;
        self.file.write_all(line.as_bytes())?;
        self.file.write_all(b"\n")?;
        if self.flush_rows {
            self.file.flush()?;
        }
        self.rows += 1;
        Ok(())
    }

    /// Append the comment line `# {text}` (CSV readers skip it with `comment="#"`).
    pub fn comment(&mut self, text: &str) -> Result<()> {
        let line = format!("# {}\n", comment_text(text));
        self.file.write_all(line.as_bytes())?;
        Ok(())
    }

    /// End the file with `# {status}` and rename it into place.
    pub fn finish(mut self, status: &str) -> Result<()> {
        let line = format!("# {}\n", comment_text(status));
        self.file.write_all(line.as_bytes())?;
        self.file.commit()
    }
}

/// `text` on one comment line: line breaks become spaces, other control characters are
/// escaped (`\u{1b}`), so that a model's name or a message cannot break the CSV or act on a
/// terminal that shows it.
pub fn comment_text(text: &str) -> String {
    super::one_line(&text.replace('\n', " "))
}
