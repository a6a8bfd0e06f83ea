//! Accounting of the GPU memory each renderer allocates, by category, so `render` and
//! `bench` can print what a configuration costs. Depends on nothing.

use std::fmt;

/// Bytes allocated per named category (e.g. "scene.vertices", "forward.tile_lists").
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct MemoryReport {
    /// (category, bytes), in the order they were added.
    pub entries: Vec<(String, u64)>,
    /// (category, text): what a category's bytes are made of, printed after its line
    /// (e.g. the G-buffer's bytes a sample).
    pub notes: Vec<(String, String)>,
}

impl MemoryReport {
    /// Adds `bytes` under `category` (summed with an existing entry of that name).
    pub fn add(&mut self, category: &str, bytes: u64) {
        match self.entries.iter_mut().find(|(c, _)| c == category) {
            Some((_, b)) => *b += bytes,
            None => self.entries.push((category.to_string(), bytes)),
        }
    }

    /// Sets `category` to `bytes` (added at the end when absent), e.g. after a buffer grew.
    pub fn set(&mut self, category: &str, bytes: u64) {
        match self.entries.iter_mut().find(|(c, _)| c == category) {
            Some((_, b)) => *b = bytes,
            None => self.entries.push((category.to_string(), bytes)),
        }
    }

    /// Sets the note printed after `category`'s line.
    pub fn note(&mut self, category: &str, text: impl Into<String>) {
        self.notes.retain(|(c, _)| c != category);
        self.notes.push((category.to_string(), text.into()));
    }

    /// Appends every entry (and note) of `other`.
    pub fn extend(&mut self, other: &MemoryReport) {
        for (c, b) in &other.entries {
            self.add(c, *b);
        }
        for (c, t) in &other.notes {
            self.note(c, t.clone());
        }
    }

    /// Total bytes.
    pub fn total(&self) -> u64 {
        self.entries.iter().map(|(_, b)| b).sum()
    }

    /// Bytes of one category (0 if absent).
    pub fn get(&self, category: &str) -> u64 {
        self.entries.iter().find(|(c, _)| c == category).map_or(0, |(_, b)| *b)
    }
}

/// Formats a byte count with binary units.
pub fn format_bytes(b: u64) -> String {
    const UNITS: [&str; 4] = ["B", "KiB", "MiB", "GiB"];
    let mut v = b as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{b} B")
    } else {
        format!("{v:.2} {}", UNITS[u])
    }
}

impl fmt::Display for MemoryReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (c, b) in &self.entries {
            match self.notes.iter().find(|(n, _)| n == c) {
                Some((_, t)) => writeln!(f, "  {c:<28} {:>12}  ({t})", format_bytes(*b))?,
                None => writeln!(f, "  {c:<28} {:>12}", format_bytes(*b))?,
            }
        }
        write!(f, "  {:<28} {:>12}", "total", format_bytes(self.total()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sums_categories() {
        let mut m = MemoryReport::default();
        m.add("a", 10);
        m.add("b", 5);
        m.add("a", 1);
        assert_eq!(m.get("a"), 11);
        assert_eq!(m.total(), 16);
        assert_eq!(format_bytes(1536), "1.50 KiB");
        m.note("b", "5 B a sample");
        let text = m.to_string();
        assert!(text.contains("(5 B a sample)") && !text.lines().next().unwrap().contains('('), "{text}");
    }
}
