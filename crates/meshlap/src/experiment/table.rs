//! [`Table`]: a result table with a caption, a header and notes, as GitHub-flavoured
//! Markdown and RFC 4180 CSV; and the number formats of the tables ([`sig`],
//! [`yes_no`]).

use serde::Serialize;

/// A result table: a header and rows of already formatted cells.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct Table {
    /// Caption.
    pub title: String,
    /// Column names.
    pub header: Vec<String>,
    /// Rows, each as long as the header.
    pub rows: Vec<Vec<String>>,
    /// Notes printed under the table.
    pub notes: Vec<String>,
}

/// A column of [`Table::from_columns`]: its name and how a row formats its cell.
pub type Column<'a, R> = (&'a str, &'a dyn Fn(&R) -> String);

impl Table {
    /// An empty table with a caption and column names.
    pub fn new(title: impl Into<String>, header: &[&str]) -> Self {
        Table {
            title: title.into(),
            header: header.iter().map(|s| s.to_string()).collect(),
            ..Default::default()
        }
    }

    /// A table of `rows`, one column per `(name, cell)`: each column's name beside
    /// the function that formats its cell, so the two cannot drift apart.
    pub fn from_columns<R>(
        title: impl Into<String>,
        rows: impl IntoIterator<Item = R>,
        columns: &[Column<'_, R>],
    ) -> Self {
        Table {
            title: title.into(),
            header: columns.iter().map(|(name, _)| name.to_string()).collect(),
            rows: rows
                .into_iter()
                .map(|r| columns.iter().map(|(_, cell)| cell(&r)).collect())
                .collect(),
            ..Default::default()
        }
    }

    /// Appends a row (padded or truncated to the header's width).
    pub fn push(&mut self, row: Vec<String>) {
        let mut row = row;
        row.resize(self.header.len(), String::new());
        self.rows.push(row);
    }

    /// GitHub-flavoured Markdown, columns padded for reading as plain text.
    pub fn to_markdown(&self) -> String {
        let esc = |s: &str| s.replace('|', "\\|");
        let widths: Vec<usize> = (0..self.header.len())
            .map(|c| {
                self.rows
                    .iter()
                    .map(|r| esc(&r[c]).chars().count())
                    .chain([esc(&self.header[c]).chars().count(), 3])
                    .max()
                    .unwrap_or(3)
            })
            .collect();
        let line = |cells: &[String]| {
            let mut s = String::from("|");
            for (c, w) in cells.iter().zip(&widths) {
                let e = esc(c);
                s += &format!(" {e}{} |", " ".repeat(w - e.chars().count()));
            }
            s + "\n"
        };
        let mut out = String::new();
        if !self.title.is_empty() {
            out += &format!("**{}**\n\n", self.title);
        }
        out += &line(&self.header);
        out += "|";
        for w in &widths {
            out += &format!("{}|", "-".repeat(w + 2));
        }
        out += "\n";
        for r in &self.rows {
            out += &line(r);
        }
        for n in &self.notes {
            out += &format!("\n{n}\n");
        }
        out
    }

    /// RFC 4180 CSV (header first).
    pub fn to_csv(&self) -> String {
        let cell = |s: &String| {
            if s.contains([',', '"', '\n']) {
                format!("\"{}\"", s.replace('"', "\"\""))
            } else {
                s.clone()
            }
        };
        std::iter::once(&self.header)
            .chain(&self.rows)
            .map(|r| r.iter().map(cell).collect::<Vec<_>>().join(",") + "\n")
            .collect()
    }
}

/// Formats a float with `digits` significant digits, or `n/a`.
pub fn sig(v: Option<f64>, digits: usize) -> String {
    match v {
        None => "n/a".into(),
        Some(0.0) => "0".into(),
        Some(x) if !x.is_finite() => format!("{x}"),
        Some(x) => {
            let a = x.abs();
            if (1e-3..1e5).contains(&a) {
                let decimals = (digits as i32 - 1 - a.log10().floor() as i32).max(0) as usize;
                format!("{x:.decimals$}")
            } else {
                format!("{x:.prec$e}", prec = digits.saturating_sub(1))
            }
        }
    }
}

/// `yes` / `no`, or `n/a`.
pub fn yes_no(v: Option<bool>) -> String {
    match v {
        Some(true) => "yes".into(),
        Some(false) => "no".into(),
        None => "n/a".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn markdown_and_csv() {
        let mut t = Table::new("T", &["a", "b|c"]);
        t.push(vec!["1".into(), "x,y".into()]);
        t.push(vec!["22".into()]);
        t.notes.push("note".into());
        let md = t.to_markdown();
        assert!(
            md.starts_with(
                "**T**\n\n| a   | b\\|c |\n|-----|------|\n| 1   | x,y  |\n| 22  |      |\n"
            ),
            "{md}"
        );
        assert!(md.ends_with("\nnote\n"));
        assert_eq!(t.to_csv(), "a,b|c\n1,\"x,y\"\n22,\n");
    }

    #[test]
    fn columns_pair_names_with_cells() {
        let rows = [(1, "x"), (22, "y")];
        let t = Table::from_columns(
            "T",
            &rows,
            &[
                ("n", &|r: &&(i32, &str)| r.0.to_string()),
                ("s", &|r| r.1.to_uppercase()),
            ],
        );
        assert_eq!(t.header, ["n", "s"]);
        assert_eq!(t.to_csv(), "n,s\n1,X\n22,Y\n");
    }

    #[test]
    fn number_formatting() {
        assert_eq!(sig(Some(0.7312), 3), "0.731");
        assert_eq!(sig(Some(123.456), 3), "123");
        assert_eq!(sig(Some(1.5e-12), 2), "1.5e-12");
        assert_eq!(sig(None, 2), "n/a");
        assert_eq!(sig(Some(0.0), 2), "0");
        assert_eq!(yes_no(Some(true)), "yes");
    }
}
