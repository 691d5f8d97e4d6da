//! One table type for every report: aligned terminal text, Markdown and CSV from the same rows.

use serde::Serialize;

/// A column of [`Table::of`]: its header, and its cell of an item.
pub type Column<'a, T> = (&'a str, &'a dyn Fn(&T) -> String);

#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Table {
    pub headers: Vec<String>,
    pub rows: Vec<Vec<String>>,
}

impl Table {
    pub fn new<S: Into<String>>(headers: impl IntoIterator<Item = S>) -> Table {
        Table { headers: headers.into_iter().map(Into::into).collect(), rows: Vec::new() }
    }

    pub fn row<S: ToString>(&mut self, cells: impl IntoIterator<Item = S>) {
        self.rows.push(cells.into_iter().map(|c| c.to_string()).collect());
    }

    /// One row per item, one cell per column: each header is written beside the cell it heads.
    pub fn of<T>(items: impl IntoIterator<Item = T>, columns: &[Column<'_, T>]) -> Table {
        let mut t = Table::new(columns.iter().map(|c| c.0));
        for item in items {
            t.row(columns.iter().map(|c| (c.1)(&item)));
        }
        t
    }

    fn widths(&self) -> Vec<usize> {
        let mut w: Vec<usize> = self.headers.iter().map(|h| h.chars().count()).collect();
        for r in &self.rows {
            for (i, c) in r.iter().enumerate() {
                if i < w.len() {
                    w[i] = w[i].max(c.chars().count());
                }
            }
        }
        w
    }

    /// Columns of numbers only are right-aligned.
    fn numeric(&self) -> Vec<bool> {
        (0..self.headers.len())
            .map(|i| {
                self.rows.iter().all(|r| {
                    r.get(i).is_none_or(|c| {
                        c.is_empty() || c.trim_end_matches(['%', 'x', '×']).parse::<f64>().is_ok()
                    })
                })
            })
            .collect()
    }

    /// Aligned columns for the terminal.
    pub fn to_text(&self) -> String {
        let w = self.widths();
        let num = self.numeric();
        let line = |cells: &[String]| {
            let parts: Vec<String> = cells
                .iter()
                .enumerate()
                .map(|(i, c)| if num[i] { format!("{c:>0$}", w[i]) } else { format!("{c:<0$}", w[i]) })
                .collect();
            parts.join("  ").trim_end().to_string()
        };
        let mut out = line(&self.headers);
        out.push('\n');
        out.push_str(&w.iter().map(|&n| "-".repeat(n)).collect::<Vec<_>>().join("  "));
        out.push('\n');
        for r in &self.rows {
            out.push_str(&line(r));
            out.push('\n');
        }
        out
    }

    pub fn to_markdown(&self) -> String {
        let esc = |c: &String| c.replace('|', "\\|");
        let mut out = format!("| {} |\n", self.headers.iter().map(esc).collect::<Vec<_>>().join(" | "));
        let align: Vec<&str> = self.numeric().iter().map(|&n| if n { "---:" } else { "---" }).collect();
        out.push_str(&format!("| {} |\n", align.join(" | ")));
        for r in &self.rows {
            out.push_str(&format!("| {} |\n", r.iter().map(esc).collect::<Vec<_>>().join(" | ")));
        }
        out
    }

    pub fn to_csv(&self) -> String {
        let cell = |c: &String| {
            if c.contains([',', '"', '\n']) {
                format!("\"{}\"", c.replace('"', "\"\""))
            } else {
                c.clone()
            }
        };
        let mut out = String::new();
        for r in std::iter::once(&self.headers).chain(&self.rows) {
            out.push_str(&r.iter().map(cell).collect::<Vec<_>>().join(","));
            out.push('\n');
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_all_three_formats() {
        let mut t = Table::new(["field", "bits"]);
        t.row(["top", "3"]);
        t.row(["a,b", "10"]);
        assert_eq!(t.to_text(), "field  bits\n-----  ----\ntop       3\na,b      10\n");
        assert_eq!(t.to_markdown(), "| field | bits |\n| --- | ---: |\n| top | 3 |\n| a,b | 10 |\n");
        assert_eq!(t.to_csv(), "field,bits\ntop,3\n\"a,b\",10\n");
        t.row(["x", "many"]);
        assert!(t.to_text().ends_with("x      many\n"), "a text column is left-aligned");
        let columns: [Column<(&str, u32)>; 2] =
            [("field", &|r| r.0.to_string()), ("bits", &|r| r.1.to_string())];
        let of = Table::of([("top", 3), ("a,b", 10)], &columns);
        assert_eq!(of.to_csv(), "field,bits\ntop,3\n\"a,b\",10\n");
    }
}
