//! The boxed-MLCP text format (full description: `docs/MLCP_FORMAT.md` at the repository root).
//!
//! One problem per file, whitespace-separated tokens in any line layout; lines whose first non-blank
//! character is `#` are comments.
//!
//! ```text
//! # comment
//! n nub            (dense)   or   n nub nnz   (sparse)   -- the header, alone on its line
//! A        dense:  n*n numbers, row-major
//!          sparse: nnz triplets "i j value", 0-based, every stored entry of BOTH triangles
//! b        n numbers
//! lo       n numbers  ('-inf' allowed)
//! hi       n numbers  ('inf' allowed)
//! findex   n integers (-1 = none, j >= 0 = friction row coupled to normal row j)
//! [warm    optional warm-start section: the word `warm`, then
//!  lambda0 n numbers
//!  index0  n letters: F (free), L (at lo), U (at hi)]
//! ```
//!
//! Numbers are anything Rust's `f64` parser accepts, which includes `inf`, `+inf`, `-inf`,
//! `Infinity` and `NaN` in any letter case. `nub` is informational (checked to lie in `0..=n`); the
//! solver reads the bounds. Readers report the 1-based line and column of the offending token
//! ([`MlcpFileError::Parse`]; a missing token is reported just past the last token read), or the
//! validation error of [`Mlcp::new`] ([`MlcpFileError::Invalid`]). They never panic, and never
//! allocate more than the input can fill: `n` is capped at [`MAX_N`], a dense `A` at
//! [`MAX_DENSE_ENTRIES`] numbers.
//!
//! Writers use `{:e}` (shortest representation that round-trips, so `write → parse` is exact) and
//! pick the sparse form when fewer than a quarter of the `n²` entries are stored. A problem with a
//! warm start (`lambda0`, `index0`: the previous step's impulses and index set, as the simulation
//! hands them to the solver) is written with the optional `warm` section; files without it read as
//! before (the section is backwards compatible: it is the only thing that may follow `findex`). A
//! warm section with only `lambda0` or only `index0` is not written; on reading, both are required.
//!
//! Solution files: `n` numbers, one per line, 17 significant digits (`{:.16e}`).

use std::io::Write;
use std::path::{Path, PathBuf};

use thiserror::Error;

use super::problem::{IndexState, Mlcp, MlcpError, SymCsr};

/// Largest problem size a reader accepts.
pub const MAX_N: usize = 1_000_000;

/// Largest number of entries (`n²`) a reader accepts for a dense `A`.
pub const MAX_DENSE_ENTRIES: usize = 200_000_000;

/// Longest token quoted verbatim in an error message; longer ones are shortened.
const MAX_QUOTED_CHARS: usize = 40;

/// Errors reading a problem or solution file.
#[derive(Debug, Error)]
pub enum MlcpFileError {
    /// The file could not be read.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The text does not follow the format. Line and column (1-based, columns in characters) of the
    /// offending token, or just past the last token when the file ends early.
    #[error("line {line}, column {column}: {message}")]
    Parse {
        /// 1-based line.
        line: usize,
        /// 1-based column, in characters.
        column: usize,
        /// What was expected and what was found.
        message: String,
    },
    /// The text follows the format but the problem fails validation ([`Mlcp::new`]).
    #[error("invalid problem: {source}")]
    Invalid {
        /// The validation error.
        #[from]
        source: MlcpError,
    },
}

/// A whitespace-delimited token and where it starts.
#[derive(Debug, Clone, Copy)]
struct Token<'a> {
    text: &'a str,
    line: usize,
    column: usize,
}

impl Token<'_> {
    fn error(&self, message: String) -> MlcpFileError {
        MlcpFileError::Parse { line: self.line, column: self.column, message }
    }

    /// The token for an error message, shortened when very long.
    fn quoted(&self) -> String {
        if self.text.chars().count() <= MAX_QUOTED_CHARS {
            format!("'{}'", self.text)
        } else {
            let head: String = self.text.chars().take(MAX_QUOTED_CHARS).collect();
            format!("'{head}...'")
        }
    }
}

/// Splits text into tokens, skipping comment lines, tracking line and column.
#[derive(Debug)]
struct Lexer<'a> {
    /// Text not yet scanned.
    rest: &'a str,
    /// Line and column of the first character of `rest`.
    line: usize,
    column: usize,
    /// Whether `rest` starts a line (so a comment check is due).
    at_line_start: bool,
    peeked: Option<Token<'a>>,
    /// Position just past the last token handed out.
    end: (usize, usize),
}

fn is_blank(c: char) -> bool {
    c != '\n' && c.is_whitespace()
}

impl<'a> Lexer<'a> {
    fn new(text: &'a str) -> Self {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        Lexer { rest: text, line: 1, column: 1, at_line_start: true, peeked: None, end: (1, 1) }
    }

    fn scan(&mut self) -> Option<Token<'a>> {
        loop {
            if self.at_line_start {
                self.at_line_start = false;
                let body = self.rest.trim_start_matches(is_blank);
                if body.starts_with('#') {
                    // Keep the newline: it moves to the next line below.
                    self.rest = &body[body.find('\n').unwrap_or(body.len())..];
                }
            }
            let rest = self.rest;
            let mut start = None;
            let mut newline = false;
            for (i, c) in rest.char_indices() {
                if c == '\n' {
                    self.line += 1;
                    self.column = 1;
                    self.at_line_start = true;
                    self.rest = &rest[i + 1..];
                    newline = true;
                    break;
                }
                if c.is_whitespace() {
                    self.column += 1;
                } else {
                    start = Some(i);
                    break;
                }
            }
            if newline {
                continue;
            }
            let Some(start) = start else {
                self.rest = "";
                return None;
            };
            let s = &rest[start..];
            let len = s.find(char::is_whitespace).unwrap_or(s.len());
            let tok = Token { text: &s[..len], line: self.line, column: self.column };
            self.column += tok.text.chars().count();
            self.rest = &s[len..];
            return Some(tok);
        }
    }

    fn next_token(&mut self) -> Option<Token<'a>> {
        let t = match self.peeked.take() {
            Some(t) => Some(t),
            None => self.scan(),
        };
        if let Some(t) = &t {
            self.end = (t.line, t.column + t.text.chars().count());
        }
        t
    }

    fn peek(&mut self) -> Option<Token<'a>> {
        if self.peeked.is_none() {
            self.peeked = self.scan();
        }
        self.peeked
    }

    /// An upper bound on the number of tokens left (each takes a character and a separator), used to
    /// cap allocations by the size of the input rather than by a header's claim.
    fn max_tokens_left(&self) -> usize {
        self.rest.len() / 2 + 2
    }

    /// An error located just past the last token read.
    fn eof(&self, message: String) -> MlcpFileError {
        MlcpFileError::Parse { line: self.end.0, column: self.end.1, message }
    }

    /// The next token, or an "unexpected end of file" error built by `expected`.
    fn expect(&mut self, expected: impl FnOnce() -> String) -> Result<Token<'a>, MlcpFileError> {
        match self.next_token() {
            Some(t) => Ok(t),
            None => Err(self.eof(format!("unexpected end of file: {}", expected()))),
        }
    }
}

fn parse_f64(t: Token<'_>, what: impl FnOnce() -> String) -> Result<f64, MlcpFileError> {
    t.text
        .parse::<f64>()
        .map_err(|_| t.error(format!("expected a number for {}, found {}", what(), t.quoted())))
}

fn parse_u64(t: Token<'_>, what: impl FnOnce() -> String) -> Result<u64, MlcpFileError> {
    t.text
        .parse::<u64>()
        .map_err(|_| t.error(format!("expected a non-negative integer for {}, found {}", what(), t.quoted())))
}

/// Reads `n` numbers of the vector `name`.
fn read_vector(lx: &mut Lexer<'_>, n: usize, name: &str) -> Result<Vec<f64>, MlcpFileError> {
    let mut v = Vec::with_capacity(n.min(lx.max_tokens_left()));
    for i in 0..n {
        let t = lx.expect(|| format!("expected {n} numbers of {name}, found {i}"))?;
        v.push(parse_f64(t, || format!("{name}[{i}]"))?);
    }
    Ok(v)
}

/// The parsed header line.
struct Header {
    n: usize,
    /// `Some(nnz)` for the sparse form.
    nnz: Option<usize>,
}

const HEADER_FORMS: &str = "'n nub' (dense) or 'n nub nnz' (sparse)";

fn read_header(lx: &mut Lexer<'_>) -> Result<Header, MlcpFileError> {
    let first = lx.expect(|| format!("expected the header {HEADER_FORMS}"))?;
    let mut toks = vec![first];
    while toks.len() < 4 && lx.peek().is_some_and(|t| t.line == first.line) {
        toks.extend(lx.next_token());
    }
    if toks.len() == 4 {
        return Err(toks[3].error(format!(
            "expected the header {HEADER_FORMS} alone on its line, found a fourth token {}",
            toks[3].quoted()
        )));
    }
    if toks.len() == 1 {
        return Err(first.error(format!(
            "expected the header {HEADER_FORMS} on one line, found the single token {}",
            first.quoted()
        )));
    }
    let n64 = parse_u64(toks[0], || "n in the header".into())?;
    if n64 > MAX_N as u64 {
        return Err(toks[0].error(format!("n = {n64} in the header exceeds the supported maximum {MAX_N}")));
    }
    let n = n64 as usize;
    let nub = parse_u64(toks[1], || "nub in the header".into())?;
    if nub > n64 {
        return Err(toks[1].error(format!("nub = {nub} in the header must lie between 0 and n = {n}")));
    }
    let nn = n64 * n64; // n <= 1e6: no overflow
    if let Some(&t) = toks.get(2) {
        let nnz = parse_u64(t, || "nnz in the header".into())?;
        if nnz > nn {
            return Err(t.error(format!("nnz = {nnz} in the header exceeds n*n = {nn}")));
        }
        Ok(Header { n, nnz: Some(nnz as usize) })
    } else {
        if nn > MAX_DENSE_ENTRIES as u64 {
            return Err(toks[0].error(format!(
                "a dense A with n = {n} has n*n = {nn} entries, more than the supported {MAX_DENSE_ENTRIES}; \
                 use the sparse form 'n nub nnz'"
            )));
        }
        Ok(Header { n, nnz: None })
    }
}

fn read_dense(lx: &mut Lexer<'_>, n: usize) -> Result<SymCsr, MlcpFileError> {
    let total = n * n;
    let mut a = Vec::with_capacity(total.min(lx.max_tokens_left()));
    for i in 0..n {
        for j in 0..n {
            let t = lx.expect(|| {
                format!("expected {total} numbers of A ({n}x{n}, row-major), found {}", i * n + j)
            })?;
            a.push(parse_f64(t, || format!("A[{i},{j}]"))?);
        }
    }
    Ok(SymCsr::from_dense_row_major(n, &a)?)
}

fn read_index(t: Token<'_>, n: usize, which: &str, k: usize) -> Result<usize, MlcpFileError> {
    let v = parse_u64(t, || format!("the {which} index of A triplet {} ('i j value')", k + 1))?;
    if v >= n as u64 {
        return Err(t.error(format!(
            "{which} index {v} of A triplet {} is out of range: expected 0 <= {which} < n = {n}",
            k + 1
        )));
    }
    Ok(v as usize)
}

fn read_sparse(lx: &mut Lexer<'_>, n: usize, nnz: usize) -> Result<SymCsr, MlcpFileError> {
    let mut triplets = Vec::with_capacity(nnz.min(lx.max_tokens_left() / 3 + 1));
    for k in 0..nnz {
        let eof = || format!("expected {nnz} triplets 'i j value' of A, found {k}");
        let i = read_index(lx.expect(eof)?, n, "row", k)?;
        let j = read_index(lx.expect(eof)?, n, "column", k)?;
        let v = parse_f64(lx.expect(eof)?, || format!("A[{i},{j}]"))?;
        triplets.push((i, j, v));
    }
    Ok(SymCsr::from_triplets(n, &triplets)?)
}

fn read_findex(lx: &mut Lexer<'_>, n: usize) -> Result<Vec<Option<usize>>, MlcpFileError> {
    let mut f = Vec::with_capacity(n.min(lx.max_tokens_left()));
    for i in 0..n {
        let t = lx.expect(|| format!("expected {n} integers of findex, found {i}"))?;
        let v = t
            .text
            .parse::<i64>()
            .map_err(|_| t.error(format!("expected an integer for findex[{i}], found {}", t.quoted())))?;
        f.push(match v {
            -1 => None,
            // A value beyond usize is out of range; validation reports it.
            v if v >= 0 => Some(usize::try_from(v).unwrap_or(usize::MAX)),
            _ => {
                return Err(t.error(format!(
                    "findex must be an integer >= -1 (-1 = none), found {} for findex[{i}]",
                    t.quoted()
                )));
            }
        });
    }
    Ok(f)
}

/// Parses a problem in the format of `MLCP_FORMAT.md` (see the module documentation).
pub fn parse_mlcp(text: &str) -> Result<Mlcp, MlcpFileError> {
    let mut lx = Lexer::new(text);
    let header = read_header(&mut lx)?;
    let n = header.n;
    let a = match header.nnz {
        None => read_dense(&mut lx, n)?,
        Some(nnz) => read_sparse(&mut lx, n, nnz)?,
    };
    let b = read_vector(&mut lx, n, "b")?;
    let lo = read_vector(&mut lx, n, "lo")?;
    let hi = read_vector(&mut lx, n, "hi")?;
    let findex = read_findex(&mut lx, n)?;
    let warm = match lx.next_token() {
        None => None,
        Some(t) if t.text == "warm" => Some(read_warm(&mut lx, n)?),
        Some(t) => {
            return Err(t.error(format!(
                "trailing data after findex: found {} (only a `warm` section may follow)",
                t.quoted()
            )));
        }
    };
    if let Some(t) = lx.next_token() {
        return Err(t.error(format!("trailing data after the warm section: found {}", t.quoted())));
    }
    let mut p = Mlcp::new(a, b, lo, hi, findex)?;
    if let Some((l0, s0)) = warm {
        p.set_warm_start(Some(&l0), Some(&s0))?;
    }
    Ok(p)
}

/// The `warm` section after its keyword: `n` numbers `λ₀`, then `n` letters F/L/U.
fn read_warm(lx: &mut Lexer<'_>, n: usize) -> Result<(Vec<f64>, Vec<IndexState>), MlcpFileError> {
    let lambda0 = read_vector(lx, n, "lambda0")?;
    let mut index0 = Vec::with_capacity(n.min(lx.max_tokens_left()));
    for i in 0..n {
        let t = lx.expect(|| format!("expected {n} letters F/L/U of index0, found {i}"))?;
        index0.push(match t.text {
            "F" => IndexState::Free,
            "L" => IndexState::Lower,
            "U" => IndexState::Upper,
            _ => {
                return Err(t.error(format!(
                    "expected F (free), L (at lo) or U (at hi) for index0[{i}], found {}",
                    t.quoted()
                )));
            }
        });
    }
    Ok((lambda0, index0))
}

/// Reads and parses a problem file.
pub fn read_mlcp_file(path: &Path) -> Result<Mlcp, MlcpFileError> {
    let text = std::fs::read_to_string(path)
        .map_err(|source| MlcpFileError::Io { path: path.to_path_buf(), source })?;
    parse_mlcp(&text)
}

/// Appends `values` to `line`, space separated, in shortest round-trip `{:e}` form.
fn push_numbers(line: &mut String, values: impl IntoIterator<Item = f64>) {
    use std::fmt::Write as _;
    for (k, x) in values.into_iter().enumerate() {
        if k > 0 {
            line.push(' ');
        }
        // Writing to a String cannot fail.
        let _ = write!(line, "{x:e}");
    }
    line.push('\n');
}

/// Writes `p` in the format of `MLCP_FORMAT.md`: the sparse form when fewer than a quarter of the
/// `n²` entries of `A` are stored, else the dense form. Numbers round-trip exactly through
/// [`parse_mlcp`]. Writes one line at a time; wrap a file in a `BufWriter` anyway for large problems.
pub fn write_mlcp<W: Write>(p: &Mlcp, out: &mut W) -> std::io::Result<()> {
    use std::fmt::Write as _;
    let a = p.a();
    let n = p.n();
    let nnz = a.nnz();
    let mut line = String::new();
    out.write_all(b"# written by pivotsim\n")?;
    if (nnz as u128) * 4 < (n as u128) * (n as u128) {
        writeln!(out, "{n} {} {nnz}", p.nub())?;
        for i in 0..n {
            let (cols, vals) = a.row(i);
            line.clear();
            for (&j, &x) in cols.iter().zip(vals) {
                let _ = writeln!(line, "{i} {j} {x:e}");
            }
            out.write_all(line.as_bytes())?;
        }
    } else {
        writeln!(out, "{n} {}", p.nub())?;
        let mut row = vec![0.0; n];
        for i in 0..n {
            row.fill(0.0);
            let (cols, vals) = a.row(i);
            for (&j, &x) in cols.iter().zip(vals) {
                row[j] = x;
            }
            line.clear();
            push_numbers(&mut line, row.iter().copied());
            out.write_all(line.as_bytes())?;
        }
    }
    for v in [p.b(), p.lo(), p.hi()] {
        line.clear();
        push_numbers(&mut line, v.iter().copied());
        out.write_all(line.as_bytes())?;
    }
    line.clear();
    for (k, f) in p.findex().iter().enumerate() {
        if k > 0 {
            line.push(' ');
        }
        match f {
            Some(j) => {
                let _ = write!(line, "{j}");
            }
            None => line.push_str("-1"),
        }
    }
    line.push('\n');
    out.write_all(line.as_bytes())?;
    if let (Some(l0), Some(s0)) = (p.lambda0(), p.index0()) {
        line.clear();
        line.push_str("warm\n");
        push_numbers(&mut line, l0.iter().copied());
        for (k, s) in s0.iter().enumerate() {
            if k > 0 {
                line.push(' ');
            }
            line.push(match s {
                IndexState::Free => 'F',
                IndexState::Lower => 'L',
                IndexState::Upper => 'U',
            });
        }
        line.push('\n');
        out.write_all(line.as_bytes())?;
    }
    Ok(())
}

/// Writes a solution: one number per line, 17 significant digits (`{:.16e}`), which round-trips
/// every finite `f64` exactly.
pub fn write_solution<W: Write>(lambda: &[f64], out: &mut W) -> std::io::Result<()> {
    use std::fmt::Write as _;
    let mut text = String::with_capacity(lambda.len() * 25);
    for &x in lambda {
        let _ = writeln!(text, "{x:.16e}");
    }
    out.write_all(text.as_bytes())
}

/// Parses a solution file: whitespace-separated numbers (any layout), comment lines allowed.
pub fn parse_solution(text: &str) -> Result<Vec<f64>, MlcpFileError> {
    let mut lx = Lexer::new(text);
    let mut v = Vec::new();
    while let Some(t) = lx.next_token() {
        let k = v.len();
        v.push(parse_f64(t, || format!("lambda[{k}]"))?);
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    const INF: f64 = f64::INFINITY;

    /// Asserts a `Parse` error and returns `(line, column, message)`.
    #[track_caller]
    fn parse_error(text: &str) -> (usize, usize, String) {
        match parse_mlcp(text) {
            Err(MlcpFileError::Parse { line, column, message }) => (line, column, message),
            other => panic!("expected a Parse error for {text:?}, got {other:?}"),
        }
    }

    #[track_caller]
    fn invalid(text: &str) -> MlcpError {
        match parse_mlcp(text) {
            Err(MlcpFileError::Invalid { source }) => source,
            other => panic!("expected an Invalid error for {text:?}, got {other:?}"),
        }
    }

    fn written(p: &Mlcp) -> String {
        let mut out = Vec::new();
        write_mlcp(p, &mut out).unwrap();
        String::from_utf8(out).unwrap()
    }

    /// The header line of a written file (first non-comment line).
    fn header_tokens(text: &str) -> Vec<String> {
        let line = text.lines().find(|l| !l.trim_start().starts_with('#') && !l.trim().is_empty()).unwrap();
        line.split_whitespace().map(str::to_owned).collect()
    }

    fn data_dir(sub: &str) -> PathBuf {
        Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data")).join(sub)
    }

    fn check_data_dir(sub: &str, min_files: usize, sparse_with_friction: bool) {
        let dir = data_dir(sub);
        let mut paths: Vec<PathBuf> = std::fs::read_dir(&dir)
            .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|x| x == "txt"))
            .collect();
        paths.sort();
        assert!(paths.len() >= min_files, "{}: only {} files", dir.display(), paths.len());
        for path in &paths {
            let p = read_mlcp_file(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            let text = std::fs::read_to_string(path).unwrap();
            let header = header_tokens(&text);
            assert_eq!(p.n(), header[0].parse::<usize>().unwrap(), "{}", path.display());
            if sparse_with_friction {
                assert_eq!(header.len(), 3, "{}: expected the sparse form", path.display());
                assert!(p.has_friction(), "{}: no findex entries", path.display());
            }
            // Every real problem survives a write/parse round trip unchanged.
            let again = parse_mlcp(&written(&p)).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            assert_eq!(again, p, "{}", path.display());
        }
    }

    #[test]
    fn siconos_files_parse() {
        check_data_dir("siconos", 10, false);
    }

    #[test]
    fn scene_shaped_files_parse_sparse_with_friction() {
        check_data_dir("scene-shaped", 4, true);
    }

    #[test]
    fn small_known_problem() {
        let text = "# a comment\n  # an indented comment\n3 0\n15.0 -1.0 -2.0\n-1.0 14.0 1.0\n-2.0 1.0 16.0\n\
                    1.0 -2.0 -3.0\n0.0 -0.1 -0.1\ninf 0.1 0.1\n-1 0 0\n";
        let p = parse_mlcp(text).unwrap();
        assert_eq!(p.n(), 3);
        assert_eq!(p.a().get(0, 2), -2.0);
        assert_eq!(p.a().get(1, 1), 14.0);
        assert_eq!(p.b(), &[1.0, -2.0, -3.0]);
        assert_eq!(p.lo(), &[0.0, -0.1, -0.1]);
        assert_eq!(p.hi(), &[INF, 0.1, 0.1]);
        assert_eq!(p.findex(), &[None, Some(0), Some(0)]);
    }

    #[test]
    fn warm_section_round_trips_and_is_optional() {
        let base = "3 0\n15.0 -1.0 -2.0\n-1.0 14.0 1.0\n-2.0 1.0 16.0\n1.0 -2.0 -3.0\n0.0 -0.1 -0.1\ninf 0.1 0.1\n-1 0 0\n";
        // Without the section: no warm start.
        let cold = parse_mlcp(base).unwrap();
        assert!(cold.lambda0().is_none() && cold.index0().is_none());
        // With it: read, and written back unchanged.
        let p = parse_mlcp(&format!("{base}warm\n0.25 -0.1 0\nF L U\n")).unwrap();
        assert_eq!(p.lambda0(), Some(&[0.25, -0.1, 0.0][..]));
        assert_eq!(p.index0(), Some(&[IndexState::Free, IndexState::Lower, IndexState::Upper][..]));
        let text = written(&p);
        assert!(text.contains("\nwarm\n"), "{text}");
        let again = parse_mlcp(&text).unwrap();
        assert_eq!(again, p);
        assert_eq!(again.lambda0(), p.lambda0());
        assert_eq!(again.index0(), p.index0());
        // A cold problem writes no section.
        assert!(!written(&cold).contains("warm"));
        // Errors: a bad letter, a short section, data after it.
        let (_, _, m) = parse_error(&format!("{base}warm\n0 0 0\nF X U\n"));
        assert!(m.contains("index0[1]") && m.contains("'X'"), "{m}");
        let (_, _, m) = parse_error(&format!("{base}warm\n0 0 0\nF L\n"));
        assert!(m.contains("expected 3 letters F/L/U of index0, found 2"), "{m}");
        let (_, _, m) = parse_error(&format!("{base}warm\n0 0\n"));
        assert!(m.contains("lambda0"), "{m}");
        let (_, _, m) = parse_error(&format!("{base}warm\n0 0 0\nF F F\nmore\n"));
        assert!(m.contains("trailing data after the warm section"), "{m}");
    }

    #[test]
    fn layout_comments_crlf_tabs_and_infinity_spellings() {
        // Tokens across arbitrary lines, a comment between sections, CRLF, tabs, all inf spellings.
        let text = concat!(
            "\u{feff}2 1\r\n1\t0 0\n  2\n",
            "# between A and b\n   # indented comment\n\n",
            "3 4 -inf -Infinity +inf INFINITY\n-1 -1",
        );
        let p = parse_mlcp(text).unwrap();
        assert_eq!(p.a().get(0, 0), 1.0);
        assert_eq!(p.a().get(1, 1), 2.0);
        assert_eq!(p.a().get(0, 1), 0.0);
        assert_eq!(p.b(), &[3.0, 4.0]);
        assert_eq!(p.lo(), &[-INF, -INF]);
        assert_eq!(p.hi(), &[INF, INF]);
        assert_eq!(p.nub(), 2);
        assert_eq!(p.findex(), &[None, None]);
        // Sparse form, entries in any order, diagonal omitted for row 1 (zero).
        let p = parse_mlcp("2 0 3\n1 0 0.5\n0 0 4\n0 1 0.5\n1 2\n-INF 0\nInf inf\n-1 -1\n").unwrap();
        assert_eq!(p.a().get(1, 0), 0.5);
        assert_eq!(p.a().get(1, 1), 0.0);
        assert_eq!(p.lo(), &[-INF, 0.0]);
        // Empty problem.
        assert_eq!(parse_mlcp("0 0\n").unwrap().n(), 0);
        assert_eq!(parse_mlcp("0 0 0\n").unwrap().n(), 0);
    }

    /// A random symmetric problem with a wide range of magnitudes, ±inf bounds and friction rows.
    fn random_problem(rng: &mut ChaCha8Rng, n: usize, density: f64) -> Mlcp {
        let value = |rng: &mut ChaCha8Rng| -> f64 {
            let m: f64 = rng.random::<f64>() - 0.5;
            let e: i32 = rng.random_range(-200..200);
            match rng.random_range(0..20) {
                0 => 5e-324,
                1 => -f64::MIN_POSITIVE,
                2 => 0.1,
                _ => m * 10f64.powi(e),
            }
        };
        let mut dense = vec![0.0; n * n];
        for i in 0..n {
            dense[i * n + i] = rng.random::<f64>() * 1e3 + 1.0;
            for j in 0..i {
                if rng.random_bool(density) {
                    let v = value(rng);
                    dense[i * n + j] = v;
                    dense[j * n + i] = v;
                }
            }
        }
        let a = SymCsr::from_dense_row_major(n, &dense).unwrap();
        let b: Vec<f64> = (0..n).map(|_| value(rng)).collect();
        let mut lo = vec![0.0; n];
        let mut hi = vec![0.0; n];
        let mut findex = vec![None; n];
        let nub = n / 5;
        for i in 0..n {
            if i < nub {
                (lo[i], hi[i]) = (-INF, INF);
                continue;
            }
            // The last row becomes a friction row if none is yet.
            let kind =
                if i + 1 == n && findex.iter().all(Option::is_none) { 3 } else { rng.random_range(0..4) };
            match kind {
                0 => (lo[i], hi[i]) = (0.0, INF),
                1 => (lo[i], hi[i]) = (-INF, rng.random::<f64>()),
                2 => {
                    let l = -rng.random::<f64>();
                    (lo[i], hi[i]) = (l, l + rng.random::<f64>() * 3.0);
                }
                _ => {
                    // Friction row on an earlier non-friction row, if any.
                    if let Some(j) = (0..i).rev().find(|&j| findex[j].is_none()) {
                        let mu = rng.random::<f64>();
                        (lo[i], hi[i]) = (-mu, mu);
                        findex[i] = Some(j);
                    } else {
                        (lo[i], hi[i]) = (0.0, INF);
                    }
                }
            }
        }
        Mlcp::new(a, b, lo, hi, findex).unwrap()
    }

    fn assert_bits_eq(x: &[f64], y: &[f64]) {
        assert_eq!(x.len(), y.len());
        for (k, (a, b)) in x.iter().zip(y).enumerate() {
            assert_eq!(a.to_bits(), b.to_bits(), "entry {k}: {a:e} vs {b:e}");
        }
    }

    fn check_round_trip(p: &Mlcp, expect_sparse: bool) {
        let text = written(p);
        assert!(text.starts_with("# written by pivotsim\n"));
        let header = header_tokens(&text);
        assert_eq!(header.len(), if expect_sparse { 3 } else { 2 }, "header {header:?}");
        assert_eq!(header[1].parse::<usize>().unwrap(), p.nub());
        let q = parse_mlcp(&text).unwrap();
        assert_eq!(&q, p);
        assert_bits_eq(q.a().values(), p.a().values());
        assert_bits_eq(q.b(), p.b());
        assert_bits_eq(q.lo(), p.lo());
        assert_bits_eq(q.hi(), p.hi());
        // Writing again gives the same text.
        assert_eq!(written(&q), text);
    }

    #[test]
    fn round_trip_dense() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x10_0001);
        for n in [1, 2, 5, 17, 40] {
            let p = random_problem(&mut rng, n, 0.8);
            if n >= 5 {
                assert!(p.lo().contains(&-INF) && p.hi().contains(&INF));
            }
            check_round_trip(&p, false);
        }
        // With friction rows.
        let p = random_problem(&mut rng, 30, 0.9);
        assert!(p.has_friction());
        check_round_trip(&p, false);
    }

    #[test]
    fn round_trip_sparse() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x10_0002);
        for n in [8, 33, 120] {
            let p = random_problem(&mut rng, n, 0.05);
            assert!(p.has_friction());
            assert!(p.lo().contains(&-INF) && p.hi().contains(&INF));
            check_round_trip(&p, true);
        }
        // Explicitly stored zeros of a sparse matrix survive (the sparse form lists every stored entry).
        let a = SymCsr::from_triplets(6, &[(0, 0, 1.0), (0, 4, 0.0), (4, 0, 0.0), (2, 2, 3.0)]).unwrap();
        assert_eq!(a.nnz(), 8);
        let p = Mlcp::new(a, vec![1.0; 6], vec![-INF; 6], vec![INF; 6], vec![None; 6]).unwrap();
        check_round_trip(&p, true);
    }

    #[test]
    fn solution_round_trip_is_bit_exact() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x10_0003);
        let mut lambda =
            vec![0.0, -0.0, 0.1, 1.0 / 3.0, 5e-324, f64::MIN_POSITIVE, f64::MAX, -f64::MAX, 1e300];
        while lambda.len() < 2000 {
            let x = f64::from_bits(rng.next_u64());
            if x.is_finite() {
                lambda.push(x);
            }
        }
        let mut out = Vec::new();
        write_solution(&lambda, &mut out).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert_eq!(text.lines().count(), lambda.len());
        assert_eq!(text.lines().nth(2).unwrap(), "1.0000000000000001e-1");
        assert_bits_eq(&parse_solution(&text).unwrap(), &lambda);
        // Comments and free layout.
        assert_eq!(parse_solution("# solution\n1 2\n\n  3e0\n").unwrap(), vec![1.0, 2.0, 3.0]);
        assert!(parse_solution("").unwrap().is_empty());
        match parse_solution("1.0\n# c\n2.0 foo\n") {
            Err(MlcpFileError::Parse { line: 3, column: 5, message }) => {
                assert!(message.contains("lambda[2]") && message.contains("'foo'"), "{message}")
            }
            other => panic!("{other:?}"),
        }
    }

    /// A valid dense 2x2 problem, line by line, for the error tests.
    const HEAD: &str = "# c\n2 0\n2 1\n1 2\n";

    #[test]
    fn empty_and_bad_headers() {
        let (l, c, m) = parse_error("");
        assert_eq!((l, c), (1, 1));
        assert!(m.contains("unexpected end of file") && m.contains("header"), "{m}");
        let (l, _, m) = parse_error("# only\n# comments\n");
        assert_eq!(l, 1);
        assert!(m.contains("unexpected end of file"), "{m}");
        let (l, c, m) = parse_error("# c\n2 x\n");
        assert_eq!((l, c), (2, 3));
        assert!(m.contains("nub") && m.contains("'x'"), "{m}");
        let (l, c, m) = parse_error("\n\n  2\n1 0 0 1\n");
        assert_eq!((l, c), (3, 3));
        assert!(m.contains("header"), "{m}");
        let (l, c, m) = parse_error("2 0 4 9\n");
        assert_eq!((l, c), (1, 7));
        assert!(m.contains("fourth token '9'"), "{m}");
        let (l, c, m) = parse_error("2 3\n");
        assert_eq!((l, c), (1, 3));
        assert!(m.contains("nub = 3"), "{m}");
        let (l, c, m) = parse_error("2 -1\n");
        assert_eq!((l, c), (1, 3));
        assert!(m.contains("non-negative integer for nub"), "{m}");
        let (_, _, m) = parse_error("2.5 0\n");
        assert!(m.contains("for n in the header, found '2.5'"), "{m}");
        let (l, c, m) = parse_error("2 0 5\n");
        assert_eq!((l, c), (1, 5));
        assert!(m.contains("nnz = 5"), "{m}");
    }

    #[test]
    fn huge_headers_are_errors_not_allocations() {
        let (l, c, m) = parse_error("99999999999 0\n");
        assert_eq!((l, c), (1, 1));
        assert!(m.contains("exceeds the supported maximum"), "{m}");
        let (_, _, m) = parse_error("99999999999999999999999 0\n");
        assert!(m.contains("non-negative integer for n"), "{m}");
        let (_, _, m) = parse_error("20000 0\n");
        assert!(m.contains("sparse form"), "{m}");
        // Allowed sizes, but the file holds nothing: an end-of-file error, allocating by the input size.
        let (l, _, m) = parse_error("14000 0\n1 2 3\n");
        assert_eq!(l, 2);
        assert!(m.contains("expected 196000000 numbers of A (14000x14000, row-major), found 3"), "{m}");
        let (_, _, m) = parse_error("1000000 0 1000000000000\n0 0 1\n");
        assert!(m.contains("expected 1000000000000 triplets 'i j value' of A, found 1"), "{m}");
    }

    #[test]
    fn malformed_data_is_located() {
        // Non-numeric token in A.
        let (l, c, m) = parse_error("# c\n2 0\n2 1\n1 abc\n1 2\n0 0\n1 1\n-1 -1\n");
        assert_eq!((l, c), (4, 3));
        assert_eq!(m, "expected a number for A[1,1], found 'abc'");
        // Truncated b: reported just past the last token.
        let (l, c, m) = parse_error(&format!("{HEAD}5\n"));
        assert_eq!((l, c), (5, 2));
        assert_eq!(m, "unexpected end of file: expected 2 numbers of b, found 1");
        // Truncated dense A.
        let (l, _, m) = parse_error("2 0\n1 0\n0\n");
        assert_eq!(l, 3);
        assert!(m.contains("expected 4 numbers of A (2x2, row-major), found 3"), "{m}");
        // Bad bound.
        let (l, c, m) = parse_error(&format!("{HEAD}1 1\n0 -infx\n"));
        assert_eq!((l, c), (6, 3));
        assert_eq!(m, "expected a number for lo[1], found '-infx'");
        // findex -2.
        let (l, c, m) = parse_error(&format!("{HEAD}1 1\n0 0\ninf inf\n-1 -2\n"));
        assert_eq!((l, c), (8, 4));
        assert!(m.contains("findex must be an integer >= -1") && m.contains("findex[1]"), "{m}");
        // Non-integer findex.
        let (l, c, m) = parse_error(&format!("{HEAD}1 1\n0 0\ninf inf\n1.0 -1\n"));
        assert_eq!((l, c), (8, 1));
        assert_eq!(m, "expected an integer for findex[0], found '1.0'");
        // Truncated findex.
        let (l, _, m) = parse_error(&format!("{HEAD}1 1\n0 0\ninf inf\n-1\n"));
        assert_eq!(l, 8);
        assert!(m.contains("expected 2 integers of findex, found 1"), "{m}");
        // Trailing garbage.
        let (l, c, m) = parse_error(&format!("{HEAD}1 1\n0 0\ninf inf\n-1 -1\n\n# ok\n  junk\n"));
        assert_eq!((l, c), (11, 3));
        assert_eq!(m, "trailing data after findex: found 'junk' (only a `warm` section may follow)");
        // Sparse index out of range and non-integer index.
        let (l, c, m) = parse_error("2 0 2\n0 0 1\n1 2 1\n1 1\n0 0\n1 1\n-1 -1\n");
        assert_eq!((l, c), (3, 3));
        assert!(m.contains("column index 2 of A triplet 2 is out of range"), "{m}");
        let (l, c, m) = parse_error("2 0 2\n0 0 1\n-1 1 1\n1 1\n0 0\n1 1\n-1 -1\n");
        assert_eq!((l, c), (3, 1));
        assert!(m.contains("row index of A triplet 2") && m.contains("'-1'"), "{m}");
        // Truncated sparse triplets.
        let (l, _, m) = parse_error("2 0 2\n0 0 1\n1 1\n");
        assert_eq!(l, 3);
        assert!(m.contains("expected 2 triplets 'i j value' of A, found 1"), "{m}");
        // Columns count characters, not bytes; very long tokens are shortened.
        let (l, c, m) = parse_error(&format!("2 0\nλ é {}\n", "x".repeat(1000)));
        assert_eq!((l, c), (2, 1));
        assert!(m.contains("'λ'"), "{m}");
        let (_, c, m) = parse_error(&format!("1 0\n1 2 {}\n", "x".repeat(1000)));
        assert_eq!(c, 5);
        assert!(m.len() < 200, "{m}");
        // The error's Display names the place.
        let e = parse_mlcp("# c\n2 0\n2 1\n1 abc\n").unwrap_err();
        assert!(e.to_string().starts_with("line 4, column 3: expected a number"), "{e}");
    }

    #[test]
    fn invalid_problems_report_validation_errors() {
        // NaN parses as a number; validation rejects it.
        let e = invalid(&format!("{HEAD}1 nan\n0 0\ninf inf\n-1 -1\n"));
        assert!(matches!(e, MlcpError::NonFiniteVector { vector: "b", index: 1, .. }), "{e:?}");
        // findex out of range.
        let e = invalid(&format!("{HEAD}1 1\n0 -1\ninf 1\n-1 7\n"));
        assert_eq!(e, MlcpError::FindexOutOfRange { row: 1, target: 7 });
        // Duplicate sparse triplet.
        let e = invalid("2 0 3\n0 0 1\n1 1 1\n0 0 2\n1 1\n0 0\n1 1\n-1 -1\n");
        assert_eq!(e, MlcpError::DuplicateEntry { row: 0, col: 0 });
        // Asymmetric dense matrix, inf in A, empty box.
        assert!(matches!(invalid("2 0\n2 1\n0 2\n1 1\n0 0\n1 1\n-1 -1\n"), MlcpError::NotSymmetric { .. }));
        assert!(matches!(invalid("1 0\ninf\n1\n0\n1\n-1\n"), MlcpError::NonFiniteMatrix { .. }));
        assert!(matches!(invalid("1 0\n1\n1\n2\n1\n-1\n"), MlcpError::EmptyBox { index: 0, .. }));
        let e = parse_mlcp("1 0\n1\n1\n2\n1\n-1\n").unwrap_err();
        assert!(e.to_string().starts_with("invalid problem: "), "{e}");
    }

    #[test]
    fn missing_file_is_an_io_error() {
        let path = Path::new("/nonexistent/pivotsim/problem.txt");
        match read_mlcp_file(path) {
            Err(MlcpFileError::Io { path: p, .. }) => assert_eq!(p, path),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn mutated_files_never_panic() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x10_0004);
        let seeds = [written(&random_problem(&mut rng, 6, 0.7)), written(&random_problem(&mut rng, 12, 0.1))];
        let pieces = [
            "",
            " ",
            "\n",
            "#",
            "-",
            "-1",
            "-2",
            "0",
            "99999999999",
            "nan",
            "inf",
            "x",
            "λ",
            "1e999",
            "\r\n",
        ];
        for seed in &seeds {
            let chars: Vec<char> = seed.chars().collect();
            for _ in 0..3000 {
                let mut c = chars.clone();
                for _ in 0..rng.random_range(1..4) {
                    let at = rng.random_range(0..c.len());
                    let end = (at + rng.random_range(0..6)).min(c.len());
                    let piece = pieces[rng.random_range(0..pieces.len())];
                    c.splice(at..end, piece.chars());
                }
                let text: String = c.into_iter().collect();
                let _ = parse_mlcp(&text);
                let _ = parse_solution(&text);
                // Truncations.
                let cut = text.char_indices().nth(rng.random_range(0..text.chars().count().max(1)));
                let _ = parse_mlcp(&text[..cut.map_or(0, |(i, _)| i)]);
            }
        }
    }
}
