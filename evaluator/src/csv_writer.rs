//! Every CSV the project writes goes through [`CsvWriter`]: RFC 4180 with minimal
//! quoting — what pandas' `to_csv` and Python's `csv` module write (a field is quoted
//! when it holds the delimiter, a quote or a line break, quotes doubled) — so the
//! bit-exact OSMa-Bench files and the leaderboard's exports share one writer. And
//! [`spreadsheet_safe`] is the one place where text participants chose (team and method
//! names) is defused for spreadsheets.

use std::borrow::Cow;

/// How lines end: `\n` as pandas writes on Linux, `\r\n` as Python's `csv` module.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LineEnd {
    Lf,
    CrLf,
}

/// A CSV document built in memory.
pub struct CsvWriter {
    writer: csv::Writer<Vec<u8>>,
}

impl CsvWriter {
    pub fn new(line_end: LineEnd) -> Self {
        let terminator = match line_end {
            LineEnd::Lf => csv::Terminator::Any(b'\n'),
            LineEnd::CrLf => csv::Terminator::CRLF,
        };
        let writer = csv::WriterBuilder::new().terminator(terminator).quote_style(csv::QuoteStyle::Necessary).flexible(true).from_writer(Vec::new());
        Self { writer }
    }

    /// Append a row of `cells` as they are (numbers formatted by the caller).
    pub fn row<S: AsRef<str>>(&mut self, cells: impl IntoIterator<Item = S>) {
        self.writer.write_record(cells.into_iter().map(|c| c.as_ref().to_string())).expect("writing to memory cannot fail");
    }

    /// The document.
    pub fn finish(self) -> String {
        let bytes = self.writer.into_inner().expect("writing to memory cannot fail");
        String::from_utf8(bytes).expect("the cells were text")
    }
}

/// Characters that make a spreadsheet cell a formula when they start it.
const FORMULA_STARTS: [char; 6] = ['=', '+', '-', '@', '\t', '\r'];
/// Characters a spreadsheet may split a line into cells at (the comma of this CSV, the
/// semicolon of many locales' CSV, tab, pipe) or a line break.
const CELL_BREAKS: [char; 6] = [',', ';', '\t', '|', '\n', '\r'];

/// Text a participant chose, made safe for spreadsheets: wherever a cell could start —
/// at the beginning, or after a separator some locale splits at (`a;=1+1;b` is three cells
/// in a semicolon locale), spaces skipped as an importer trims them — a formula start
/// (`=`, `+`, `-`, `@`, tab, carriage return) gets a leading apostrophe, so Excel,
/// LibreOffice and Google Sheets keep it as text (OWASP, "CSV injection"). Numbers never go
/// through here (a negative number stays a number).
pub fn spreadsheet_safe(text: &str) -> Cow<'_, str> {
    let mut out = String::with_capacity(text.len() + 2);
    let mut cell_may_start = true;
    let mut changed = false;
    for c in text.chars() {
        if cell_may_start && c == ' ' {
            out.push(c);
            continue;
        }
        if cell_may_start && FORMULA_STARTS.contains(&c) {
            out.push('\'');
            changed = true;
        }
        out.push(c);
        cell_may_start = CELL_BREAKS.contains(&c);
    }
    if changed { Cow::Owned(out) } else { Cow::Borrowed(text) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_are_quoted_as_pandas_quotes_them_and_formulas_are_defused_wherever_a_cell_may_start() {
        let mut csv = CsvWriter::new(LineEnd::Lf);
        csv.row(["plain", "with,comma", "with \"quote\"", "two\nlines", "", "0.5", "-0.25"]);
        csv.row([spreadsheet_safe("=HYPERLINK(\"http://x\")"), spreadsheet_safe("@SUM(A1)"), spreadsheet_safe("-2+3"), spreadsheet_safe("ConceptGraphs")]);
        assert_eq!(
            csv.finish(),
            "plain,\"with,comma\",\"with \"\"quote\"\"\",\"two\nlines\",,0.5,-0.25\n\"'=HYPERLINK(\"\"http://x\"\")\",'@SUM(A1),'-2+3,ConceptGraphs\n"
        );
        for (hostile, defused) in [
            ("a;=1+1;b", "a;'=1+1;b"),
            ("  =1+1", "  '=1+1"),
            ("x,@cmd", "x,'@cmd"),
            ("tab\t+1", "tab\t'+1"),
            ("pipe| -2", "pipe| '-2"),
            ("line\n=A1", "line\n'=A1"),
            ("ok a=b c-d", "ok a=b c-d"),
        ] {
            assert_eq!(spreadsheet_safe(hostile), defused, "{hostile:?}");
        }
        let mut crlf = CsvWriter::new(LineEnd::CrLf);
        crlf.row(["a", "b\rc"]);
        assert_eq!(crlf.finish(), "a,\"b\rc\"\r\n");
    }
}
