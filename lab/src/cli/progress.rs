//! The progress bar of the long photo commands (training, evaluation, colour calibration):
//! count, elapsed time and ETA on stderr, drawn only when stderr is a terminal.

use indicatif::{ProgressBar, ProgressStyle};

/// A bar of `len` items named `what`.
pub fn bar(len: usize, what: &str) -> ProgressBar {
    let bar = ProgressBar::new(len as u64);
    let style = ProgressStyle::with_template(&format!(
        "{what} [{{elapsed_precise}}] {{bar:30}} {{pos:>5}}/{{len}} eta {{eta:>3}} {{msg}}"
    ))
    .unwrap_or_else(|_| ProgressStyle::default_bar());
    bar.set_style(style);
    bar
}

/// `n` and `word`, plural unless `n` is one: "1 candidate", "3 candidates".
pub fn count(n: usize, word: &str) -> String {
    if n == 1 {
        format!("1 {word}")
    } else {
        format!("{n} {word}s")
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn one_is_singular_and_the_rest_plural() {
        assert_eq!(super::count(1, "label file"), "1 label file");
        assert_eq!(super::count(0, "candidate"), "0 candidates");
        assert_eq!(super::count(12, "ball"), "12 balls");
    }
}
