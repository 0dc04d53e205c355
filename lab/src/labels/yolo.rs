//! YOLO text labels: one `class cx cy w h` line per object, the box's centre and size
//! normalised to the image (0..1), the image's size taken from the image itself.
//!
//! Which class ids are balls comes from the caller ([`BallClassIds`]): given directly, or
//! from a names list (`classes.txt`, one name per line, or a `data.yaml`'s `names:`) through
//! [`BallNames`]. A class id beyond the names list is counted as a warning, as is a box
//! clipped to the image; anything else malformed is an error naming the file and line.

use crate::labels::{BallBox, BallNames, ImageLabels, LabelError, LabelWarning, checked_box};

/// The class ids that are balls, and how many classes there are when a names list said so.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct BallClassIds {
    pub ids: Vec<u32>,
    /// Classes in the names list; ids at or past it are unknown.
    pub known_classes: Option<u32>,
}

impl BallClassIds {
    /// The ball ids of a names list (the `n`-th name is class `n`).
    pub fn from_names(names: &[String], ball_names: &BallNames) -> Self {
        Self {
            ids: (0u32..)
                .zip(names)
                .filter(|(_, n)| ball_names.is_ball(n))
                .map(|(i, _)| i)
                .collect(),
            known_classes: u32::try_from(names.len()).ok(),
        }
    }
}

/// Names of a `classes.txt`: one per line, blank lines skipped.
pub fn parse_classes_txt(text: &str) -> Vec<String> {
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .map(str::to_owned)
        .collect()
}

fn unquote(s: &str) -> String {
    let s = s.trim();
    s.strip_prefix(['\'', '"'])
        .and_then(|t| t.strip_suffix(['\'', '"']))
        .unwrap_or(s)
        .to_owned()
}

/// The `names:` of a YOLO `data.yaml`, in any of its three usual spellings: a flow list
/// (`names: [ball, person]`), a block list (`- ball` lines) or a map (`0: ball` lines).
/// This is not a YAML parser: only the `names` key is read, and `None` means it is absent.
pub fn parse_data_yaml_names(text: &str) -> Option<Vec<String>> {
    let mut lines = text
        .lines()
        .skip_while(|l| !l.trim_start().starts_with("names:"));
    let first = lines.next()?;
    let rest = first.trim_start().trim_start_matches("names:").trim();
    if let Some(inner) = rest.strip_prefix('[') {
        let inner = inner.split(']').next().unwrap_or("");
        return Some(
            inner
                .split(',')
                .map(unquote)
                .filter(|n| !n.is_empty())
                .collect(),
        );
    }
    let mut names: Vec<(u32, String)> = Vec::new();
    for line in lines {
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        if !line.starts_with([' ', '\t', '-']) {
            break;
        }
        if let Some(item) = t.strip_prefix('-') {
            let next = u32::try_from(names.len()).unwrap_or(u32::MAX);
            names.push((next, unquote(item)));
        } else if let Some((k, v)) = t.split_once(':')
            && let Ok(k) = k.trim().parse::<u32>()
        {
            names.push((k, unquote(v)));
        }
    }
    names.sort_by_key(|(k, _)| *k);
    Some(names.into_iter().map(|(_, n)| n).collect())
}

/// Reads a YOLO label file for an image of `width_px` × `height_px`; `file` names it in
/// errors.
pub fn parse_yolo(
    text: &str,
    file: &str,
    width_px: u32,
    height_px: u32,
    balls: &BallClassIds,
) -> Result<ImageLabels, LabelError> {
    let mut labels = ImageLabels {
        width_px,
        height_px,
        ..ImageLabels::default()
    };
    for (n, raw) in text.lines().enumerate() {
        let line = n + 1;
        let fields: Vec<&str> = raw.split_whitespace().collect();
        if fields.is_empty() {
            continue;
        }
        let bad_line = |reason: String| LabelError::BadLine {
            file: file.to_owned(),
            line,
            reason,
        };
        if fields.len() != 5 {
            return Err(bad_line(format!(
                "{} fields; a box is `class cx cy w h`",
                fields.len()
            )));
        }
        let class: u32 = fields[0]
            .parse()
            .map_err(|_| bad_line(format!("class {:?} is not a class id", fields[0])))?;
        let mut v = [0.0; 4];
        for (k, (slot, what)) in v.iter_mut().zip(["cx", "cy", "w", "h"]).enumerate() {
            let text = fields[k + 1];
            *slot = text
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| LabelError::BadNumber {
                    file: file.to_owned(),
                    line,
                    what: what.to_owned(),
                    text: text.to_owned(),
                })?;
        }
        let [cx, cy, w, h] = v;
        if v.iter().any(|x| !(0.0..=1.0).contains(x)) {
            return Err(bad_line(format!(
                "cx cy w h = {cx} {cy} {w} {h} are not all normalised to 0..1 \
                 (pixel coordinates in a YOLO file?)"
            )));
        }
        if balls.known_classes.is_some_and(|k| class >= k) {
            labels.warnings.push(LabelWarning {
                line,
                what: format!("class {class} is not in the names list: not a ball"),
            });
            labels.others += 1;
            continue;
        }
        if !balls.ids.contains(&class) {
            labels.others += 1;
            continue;
        }
        let (iw, ih) = (f64::from(width_px), f64::from(height_px));
        let b = BallBox {
            x_min_px: (cx - 0.5 * w) * iw - 0.5,
            y_min_px: (cy - 0.5 * h) * ih - 0.5,
            x_max_px: (cx + 0.5 * w) * iw - 0.5,
            y_max_px: (cy + 0.5 * h) * ih - 0.5,
        };
        let ball = checked_box(b, width_px, height_px, file, line, &mut labels.warnings)?;
        labels.balls.push(ball);
    }
    Ok(labels)
}

/// One YOLO line of a ball box (class `class`), the inverse of [`parse_yolo`].
pub fn yolo_line(class: u32, b: &BallBox, width_px: u32, height_px: u32) -> String {
    let (iw, ih) = (f64::from(width_px), f64::from(height_px));
    let [cx, cy] = b.centre_px();
    format!(
        "{class} {:.6} {:.6} {:.6} {:.6}",
        (cx + 0.5) / iw,
        (cy + 0.5) / ih,
        b.width_px() / iw,
        b.height_px() / ih
    )
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    fn ball0() -> BallClassIds {
        BallClassIds {
            ids: vec![0],
            known_classes: None,
        }
    }

    #[test]
    fn reads_boxes_in_pixels() {
        let text = "0 0.5 0.25 0.1 0.2\n\n2 0.1 0.1 0.05 0.05\n";
        let l = parse_yolo(text, "a.txt", 200, 100, &ball0()).unwrap();
        assert_eq!((l.balls.len(), l.others), (1, 1));
        let b = l.balls[0];
        assert!((b.width_px() - 20.0).abs() < 1e-9 && (b.height_px() - 20.0).abs() < 1e-9);
        assert!((b.centre_px()[0] - 99.5).abs() < 1e-9 && (b.centre_px()[1] - 24.5).abs() < 1e-9);
        let back = parse_yolo(&yolo_line(0, &b, 200, 100), "b.txt", 200, 100, &ball0()).unwrap();
        assert!((back.balls[0].x_min_px - b.x_min_px).abs() < 1e-3);
    }

    #[test]
    fn names_lists_choose_the_ball_ids() {
        let names = parse_classes_txt("person\n\nsports ball\ncar\n");
        let ids = BallClassIds::from_names(&names, &BallNames::default());
        assert_eq!(ids.ids, vec![1]);
        assert_eq!(ids.known_classes, Some(3));
        let flow = parse_data_yaml_names("path: x\nnc: 2\nnames: ['person', \"Ball\"]\n").unwrap();
        assert_eq!(flow, vec!["person", "Ball"]);
        let block = parse_data_yaml_names("names:\n  - person\n  - football\ntrain: a\n").unwrap();
        assert_eq!(block, vec!["person", "football"]);
        let map = parse_data_yaml_names("names:\n  1: ball\n  0: person\nval: b\n").unwrap();
        assert_eq!(map, vec!["person", "ball"]);
        assert_eq!(parse_data_yaml_names("nc: 1\n"), None);
    }

    #[test]
    fn unknown_classes_and_clipped_boxes_are_warnings() {
        let ids = BallClassIds {
            ids: vec![0],
            known_classes: Some(2),
        };
        let l = parse_yolo(
            "5 0.5 0.5 0.1 0.1\n0 0.99 0.5 0.1 0.1\n",
            "a.txt",
            100,
            100,
            &ids,
        )
        .unwrap();
        assert_eq!((l.balls.len(), l.others, l.warnings.len()), (1, 1, 2));
        assert_eq!(l.warnings[0].line, 1);
        assert!(l.warnings[0].what.contains("class 5"));
        assert!(l.warnings[1].what.contains("clipped"));
    }

    #[test]
    fn malformed_lines_name_file_and_line() {
        let err = |t: &str| {
            parse_yolo(t, "a.txt", 100, 100, &ball0())
                .unwrap_err()
                .to_string()
        };
        let e = err("0 0.5 0.5 0.1 0.1\n0 0.5 x 0.1 0.1\n");
        assert!(e.starts_with("a.txt line 2: cy \"x\""), "{e}");
        assert!(err("0 0.5 0.5 0.1\n").contains("4 fields"));
        assert!(err("ball 0.5 0.5 0.1 0.1\n").contains("not a class id"));
        assert!(err("0 50 50 10 10\n").contains("not all normalised"));
        assert!(err("0 0.5 0.5 0 0.1\n").contains("empty"));
        assert!(err("0 0.5 0.5 NaN 0.1\n").contains("w \"NaN\""));
    }
}
