//! Text inputs (CSV files) read with a bound on a line's length: a row of the widest file the
//! tool reads (an estimates file, ~60 columns) is a few kilobytes, so a "line" of megabytes is
//! the wrong file (a binary, a file without line ends) — refused by its line number before the
//! CSV reader grows a record for it (a 100 MB line otherwise costs over a gigabyte).

use std::io::Read;
use std::path::Path;

/// The longest line accepted.
pub const MAX_LINE: usize = 1 << 20;

/// Opens a text input as [`crate::output::open_input`] does (`-`, gzip), with its lines bounded
/// by [`MAX_LINE`].
pub fn open_text(path: &Path) -> std::io::Result<Box<dyn Read + Send>> {
    Ok(Box::new(LineLimit::new(crate::output::open_input(path)?)))
}

/// A reader that fails once a line grows past [`MAX_LINE`] octets.
pub struct LineLimit<R> {
    inner: R,
    /// Octets since the last line end.
    run: usize,
    /// Line ends seen.
    lines: u64,
}

impl<R> LineLimit<R> {
    /// Wraps `inner`.
    pub fn new(inner: R) -> Self {
        LineLimit {
            inner,
            run: 0,
            lines: 0,
        }
    }
}

impl<R: Read> Read for LineLimit<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        for &b in &buf[..n] {
            if b == b'\n' {
                self.lines += 1;
                self.run = 0;
            } else {
                self.run += 1;
            }
        }
        if self.run > MAX_LINE {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!(
                    "line {}: over {} MiB without a line end: not a CSV row (the wrong file?)",
                    self.lines + 1,
                    MAX_LINE >> 20
                ),
            ));
        }
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_past_the_bound_is_refused_by_its_number() {
        let mut text = b"t,a\n1,2\n".to_vec();
        text.extend(std::iter::repeat_n(b'9', MAX_LINE + 1));
        let mut r = LineLimit::new(text.as_slice());
        let mut sink = Vec::new();
        let e = r.read_to_end(&mut sink).unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::InvalidData);
        assert!(e.to_string().starts_with("line 3: over 1 MiB"), "{e}");
    }

    #[test]
    fn lines_within_the_bound_pass_unchanged() {
        let mut text = Vec::new();
        for _ in 0..3 {
            text.extend(std::iter::repeat_n(b'x', MAX_LINE));
            text.push(b'\n');
        }
        let mut r = LineLimit::new(text.as_slice());
        let mut read = Vec::new();
        r.read_to_end(&mut read).unwrap();
        assert_eq!(read, text);
    }
}
