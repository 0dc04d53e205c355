//! Pascal VOC XML labels: `<annotation>` with `<size><width><height>` and one `<object>`
//! per labelled thing, each with a `<name>` and a `<bndbox>` of `<xmin><ymin><xmax><ymax>`
//! in 1-based pixel indices (some tools write fractions, which are accepted).
//!
//! Objects whose name is one of the [`BallNames`] are balls; the others are counted. Other
//! elements (`<folder>`, `<pose>`, `<truncated>`, `<difficult>`, `<part>` …) are ignored.
//! Errors name the file and the line of the element at fault.

use roxmltree::{Document, Node};

use crate::labels::{BallBox, BallNames, ImageLabels, LabelError, checked_box};

fn line_of(doc: &Document<'_>, node: Node<'_, '_>) -> usize {
    doc.text_pos_at(node.range().start).row as usize
}

fn child<'a, 'i>(node: Node<'a, 'i>, name: &str) -> Option<Node<'a, 'i>> {
    node.children()
        .find(|c| c.is_element() && c.tag_name().name() == name)
}

/// The text of `parent`'s child `name`, or an error naming both.
fn child_text<'a>(
    doc: &'a Document<'_>,
    parent: Node<'a, '_>,
    name: &str,
    file: &str,
) -> Result<(&'a str, usize), LabelError> {
    let node = child(parent, name).ok_or_else(|| LabelError::Missing {
        file: file.to_owned(),
        line: line_of(doc, parent),
        element: parent.tag_name().name().to_owned(),
        missing: name.to_owned(),
    })?;
    Ok((node.text().unwrap_or("").trim(), line_of(doc, node)))
}

fn number(
    doc: &Document<'_>,
    parent: Node<'_, '_>,
    name: &str,
    file: &str,
) -> Result<f64, LabelError> {
    let (text, line) = child_text(doc, parent, name, file)?;
    text.parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| LabelError::BadNumber {
            file: file.to_owned(),
            line,
            what: format!("<{name}>"),
            text: text.to_owned(),
        })
}

/// Reads a VOC annotation; `file` names it in errors.
pub fn parse_voc(
    text: &str,
    file: &str,
    ball_names: &BallNames,
) -> Result<ImageLabels, LabelError> {
    let doc = Document::parse(text).map_err(|e| LabelError::Xml {
        file: file.to_owned(),
        reason: e.to_string(),
    })?;
    let root = doc.root_element();
    if root.tag_name().name() != "annotation" {
        return Err(LabelError::BadLine {
            file: file.to_owned(),
            line: line_of(&doc, root),
            reason: format!(
                "the root element is <{}>, not <annotation>",
                root.tag_name().name()
            ),
        });
    }
    let size = child(root, "size").ok_or_else(|| LabelError::Missing {
        file: file.to_owned(),
        line: line_of(&doc, root),
        element: "annotation".into(),
        missing: "size".into(),
    })?;
    let dimension = |name: &str| -> Result<u32, LabelError> {
        let v = number(&doc, size, name, file)?;
        if v >= 1.0 && v.fract() == 0.0 && v <= f64::from(u32::MAX) {
            Ok(v as u32)
        } else {
            let (text, line) = child_text(&doc, size, name, file)?;
            Err(LabelError::BadNumber {
                file: file.to_owned(),
                line,
                what: format!("image <{name}> (a whole number of pixels, at least 1)"),
                text: text.to_owned(),
            })
        }
    };
    let mut labels = ImageLabels {
        width_px: dimension("width")?,
        height_px: dimension("height")?,
        ..ImageLabels::default()
    };
    for object in root
        .children()
        .filter(|c| c.is_element() && c.tag_name().name() == "object")
    {
        let (name, _) = child_text(&doc, object, "name", file)?;
        if !ball_names.is_ball(name) {
            labels.others += 1;
            continue;
        }
        let bndbox = child(object, "bndbox").ok_or_else(|| LabelError::Missing {
            file: file.to_owned(),
            line: line_of(&doc, object),
            element: "object".into(),
            missing: "bndbox".into(),
        })?;
        let b = BallBox {
            x_min_px: number(&doc, bndbox, "xmin", file)? - 1.5,
            y_min_px: number(&doc, bndbox, "ymin", file)? - 1.5,
            x_max_px: number(&doc, bndbox, "xmax", file)? - 0.5,
            y_max_px: number(&doc, bndbox, "ymax", file)? - 0.5,
        };
        let ball = checked_box(
            b,
            labels.width_px,
            labels.height_px,
            file,
            line_of(&doc, bndbox),
            &mut labels.warnings,
        )?;
        labels.balls.push(ball);
    }
    Ok(labels)
}

/// Writes a VOC annotation of ball boxes (named `ball`), the inverse of [`parse_voc`] to
/// the pixel: whole 1-based pixel indices as VOC tools expect (LabelImg and CVAT read no
/// fractions), each box the pixels whose centres it holds, within the image.
pub fn write_voc(file_name: &str, width_px: u32, height_px: u32, balls: &[BallBox]) -> String {
    let mut out = format!(
        "<annotation>\n  <filename>{file_name}</filename>\n  <size><width>{width_px}</width>\
         <height>{height_px}</height><depth>3</depth></size>\n"
    );
    // Pixel k (1-based) has its centre at k − 1 in box coordinates: a box holds the pixels
    // whose centres it holds, so a box read back keeps its centre.
    let index = |k: f64, size: u32| (k as i64).clamp(1, i64::from(size.max(1)));
    for b in balls {
        let x0 = index(b.x_min_px.ceil() + 1.0, width_px);
        let y0 = index(b.y_min_px.ceil() + 1.0, height_px);
        let x1 = index(b.x_max_px.floor() + 1.0, width_px).max(x0);
        let y1 = index(b.y_max_px.floor() + 1.0, height_px).max(y0);
        out += &format!(
            "  <object>\n    <name>ball</name>\n    <bndbox><xmin>{x0}</xmin><ymin>{y0}</ymin>\
             <xmax>{x1}</xmax><ymax>{y1}</ymax></bndbox>\n  </object>\n"
        );
    }
    out + "</annotation>\n"
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    const GOOD: &str = r#"<?xml version="1.0"?>
<annotation>
  <folder>photos</folder>
  <filename>a.jpg</filename>
  <size><width>640</width><height>480</height><depth>3</depth></size>
  <object>
    <name>Sports Ball</name>
    <pose>Unspecified</pose>
    <bndbox><xmin>101</xmin><ymin>51</ymin><xmax>120</xmax><ymax>70</ymax></bndbox>
  </object>
  <object>
    <name>person</name>
    <bndbox><xmin>1</xmin><ymin>1</ymin><xmax>50</xmax><ymax>200</ymax></bndbox>
  </object>
  <object>
    <name>ball</name>
    <bndbox><xmin>600.5</xmin><ymin>400</ymin><xmax>650</xmax><ymax>440</ymax></bndbox>
  </object>
</annotation>
"#;

    fn parse(text: &str) -> Result<ImageLabels, LabelError> {
        parse_voc(text, "a.xml", &BallNames::default())
    }

    #[test]
    fn reads_balls_and_counts_other_objects() {
        let l = parse(GOOD).unwrap();
        assert_eq!((l.width_px, l.height_px), (640, 480));
        assert_eq!(l.balls.len(), 2);
        assert_eq!(l.others, 1);
        let b = l.balls[0];
        assert_eq!((b.width_px(), b.height_px()), (20.0, 20.0));
        assert_eq!(b.centre_px(), [109.5, 59.5]);
        // The second ball reaches past the right edge: clipped, with a warning on its line.
        assert_eq!(l.balls[1].x_max_px, 639.5);
        assert_eq!(l.warnings.len(), 1);
        assert_eq!(l.warnings[0].line, 17);
    }

    #[test]
    fn own_ball_names() {
        let l = parse_voc(GOOD, "a.xml", &BallNames::new(["person"])).unwrap();
        assert_eq!((l.balls.len(), l.others), (1, 2));
    }

    #[test]
    fn round_trips_through_the_writer_to_the_pixel_in_whole_indices() {
        let balls = [BallBox {
            x_min_px: 10.0,
            y_min_px: 20.4,
            x_max_px: 30.2,
            y_max_px: 40.0,
        }];
        let text = write_voc("f.png", 64, 48, &balls);
        assert!(
            text.contains("<xmin>11</xmin><ymin>22</ymin><xmax>31</xmax><ymax>41</ymax>"),
            "{text}"
        );
        let l = parse(&text).unwrap();
        let b = l.balls[0];
        for (got, was) in [
            (b.x_min_px, 10.0),
            (b.y_min_px, 20.4),
            (b.x_max_px, 30.2),
            (b.y_max_px, 40.0),
        ] {
            assert!((got - was).abs() <= 0.5, "{got} against {was}");
        }
        assert_eq!((l.width_px, l.height_px, l.others), (64, 48, 0));
        // A box reaching past the image is cut at its edge.
        let edge = [BallBox {
            x_min_px: -3.0,
            y_min_px: 40.0,
            x_max_px: 70.0,
            y_max_px: 60.0,
        }];
        let text = write_voc("f.png", 64, 48, &edge);
        assert!(
            text.contains("<xmin>1</xmin><ymin>41</ymin><xmax>64</xmax><ymax>48</ymax>"),
            "{text}"
        );
    }

    fn err(text: &str) -> String {
        parse(text).unwrap_err().to_string()
    }

    #[test]
    fn malformed_files_name_file_line_and_element() {
        let bad_number = GOOD.replace("<xmin>101</xmin>", "<xmin>1o1</xmin>");
        let e = err(&bad_number);
        assert!(
            e.starts_with("a.xml line 9:") && e.contains("<xmin> \"1o1\""),
            "{e}"
        );
        let missing = GOOD.replace("<ymax>70</ymax>", "");
        let e = err(&missing);
        assert!(
            e.contains("line 9") && e.contains("<bndbox> has no <ymax>"),
            "{e}"
        );
        let no_size = GOOD.replace(
            "<size><width>640</width><height>480</height><depth>3</depth></size>",
            "",
        );
        assert!(err(&no_size).contains("<annotation> has no <size>"));
        let zero = GOOD.replace("<width>640</width>", "<width>0</width>");
        assert!(err(&zero).contains("image <width>"), "{}", err(&zero));
        let swapped = GOOD.replace("<xmax>120</xmax>", "<xmax>90</xmax>");
        let e = err(&swapped);
        assert!(e.contains("line 9") && e.contains("maximum below"), "{e}");
        let outside = GOOD.replace(
            "<xmin>101</xmin><ymin>51</ymin><xmax>120</xmax><ymax>70</ymax>",
            "<xmin>701</xmin><ymin>51</ymin><xmax>720</xmax><ymax>70</ymax>",
        );
        assert!(err(&outside).contains("outside the 640×480 image"));
        let no_box = GOOD.replace(
            "<bndbox><xmin>101</xmin><ymin>51</ymin><xmax>120</xmax><ymax>70</ymax></bndbox>",
            "",
        );
        assert!(
            err(&no_box).contains("line 6: <object> has no <bndbox>"),
            "{}",
            err(&no_box)
        );
        assert!(err("<annotation><size>").starts_with("a.xml: not XML"));
        assert!(err("<labels/>").contains("not <annotation>"));
    }
}
