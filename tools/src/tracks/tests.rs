use super::*;

fn ok(text: &str) -> TrackFile {
    parse(text, "dir/a.csv", &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

fn err(text: &str) -> TrackError {
    match parse(text, "dir/a.csv", &ReadOptions::default()) {
        Ok(f) => panic!("parsed: {f:?}"),
        Err(e) => e,
    }
}

/// `n` rows of a ball moving along x at 1 m/s, 10 ms apart, in the given columns.
fn rows(header: &str, n: usize, row: impl Fn(usize) -> String) -> String {
    let mut s = format!("{header}\n");
    for k in 0..n {
        s.push_str(&row(k));
        s.push('\n');
    }
    s
}

#[test]
fn reads_aliases_extra_columns_and_the_source_comment() {
    let text = format!(
        "# source: hand-made roll\n# another comment\n\n{}",
        rows("Frame,Time,X_m,y,confidence", 12, |k| format!(
            "{k},{},{},0.5,0.9",
            10.0 + 0.01 * k as f64,
            0.01 * k as f64
        ))
    );
    let f = ok(&text);
    assert_eq!(f.source.as_deref(), Some("hand-made roll"));
    assert_eq!(f.time_unit, TimeUnit::Seconds);
    assert_eq!(f.tracks.len(), 1);
    let t = &f.tracks[0];
    assert_eq!(t.name, "a.csv");
    assert_eq!(t.samples.len(), 12);
    // Times are relative to the first row.
    assert!(t.samples[0].t_s.abs() < 1e-12);
    assert!((t.duration_s() - 0.11).abs() < 1e-9);
    let p = t
        .position_at(0.055)
        .unwrap_or_else(|| panic!("inside the span"));
    assert!((p[0] - 0.055).abs() < 1e-9 && (p[1] - 0.5).abs() < 1e-12);
    assert_eq!(t.position_at(-0.001), None);
    assert_eq!(t.position_at(0.2), None);
}

#[test]
fn nanosecond_stamps_keep_their_precision_and_the_unit_flag_overrides() {
    let epoch: i128 = 1_767_225_600_000_000_000;
    let text = rows("stamp_ns,x,y", 10, |k| {
        format!("{},{k},0", epoch + 1_000 * k as i128 + 1)
    });
    let f = ok(&text);
    assert_eq!(f.time_unit, TimeUnit::Nanoseconds);
    assert!((f.tracks[0].samples[1].t_s - 1e-6).abs() < 1e-15);
    let plain = rows("t,x,y", 10, |k| format!("{},{k},0", 1000 * k));
    let opts = ReadOptions {
        time_unit: Some(TimeUnit::Milliseconds),
        scale: 0.001,
        offset_m: [-1.0, 2.0],
        ..ReadOptions::default()
    };
    let f = parse(&plain, "b.csv", &opts).unwrap_or_else(|e| panic!("{e}"));
    let s = f.tracks[0].samples[3];
    assert!((s.t_s - 3.0).abs() < 1e-12);
    assert!((s.position_m[0] - (-1.0 + 0.003)).abs() < 1e-12);
    assert!((s.position_m[1] - 2.0).abs() < 1e-12);
}

#[test]
fn a_track_column_splits_the_file_in_order_of_appearance() {
    let text = rows("id;t_s;x;y", 30, |k| {
        let id = if k % 3 == 0 { "kick 2" } else { "kick1" };
        format!("{id};{};{};0", 0.01 * k as f64, 0.1 * k as f64)
    });
    let f = ok(&text);
    let names: Vec<&str> = f.tracks.iter().map(|t| t.name.as_str()).collect();
    assert_eq!(names, ["a.csv#kick 2", "a.csv#kick1"]);
    assert_eq!(f.tracks[0].samples.len(), 10);
    assert_eq!(f.tracks[1].samples.len(), 20);
}

#[test]
fn nan_empty_and_repeated_rows_are_skipped_and_counted() {
    let text = rows("t,x,y", 16, |k| match k {
        3 => "0.03,NaN,1".into(),
        5 => "0.05,,1".into(),
        7 => "nan,0.1,1".into(),
        9 => "0.08,0.2,1".into(), // repeats row 8's time
        _ => format!("{},{},1", 0.01 * k as f64, 0.01 * k as f64),
    });
    let f = ok(&text);
    assert_eq!(f.rows, 16);
    assert_eq!(f.skipped_rows, 4);
    // Line 1 is the header: data row k is on line k + 2.
    assert_eq!(f.skipped_lines, vec![5, 7, 9, 11]);
    assert_eq!(f.tracks[0].samples.len(), 12);
}

#[test]
fn malformed_files_name_the_file_and_line() {
    assert_eq!(
        err("# only a comment\n\n"),
        TrackError::NoHeader {
            file: "dir/a.csv".into()
        }
    );
    let e = err("time,x_pos,y\n0,1,2\n");
    assert!(matches!(
        e,
        TrackError::MissingColumn {
            line: 1,
            what: "x",
            ..
        }
    ));
    assert!(e.to_string().contains("x, x_m"), "{e}");
    let e = err(&rows("t,x,y", 12, |k| {
        if k == 4 {
            "0.04,1".into()
        } else {
            format!("{},0,0", 0.01 * k as f64)
        }
    }));
    assert!(matches!(
        e,
        TrackError::ShortRow {
            line: 6,
            fields: 2,
            needed: 3,
            ..
        }
    ));
    let e = err(&rows("t,x,y", 12, |k| {
        if k == 2 {
            "0.02,abc,0".into()
        } else {
            format!("{},0,0", 0.01 * k as f64)
        }
    }));
    assert_eq!(e.to_string(), "dir/a.csv:4: x is \"abc\", not a number");
    let e = err(&rows("t,x,y", 12, |k| {
        format!("{},0,0", if k == 6 { 0.01 } else { 0.01 * k as f64 })
    }));
    assert!(
        matches!(e, TrackError::TimeGoesBack { line: 8, .. }),
        "{e:?}"
    );
    assert!(
        e.to_string()
            .starts_with("dir/a.csv:8: time goes backwards"),
        "{e}"
    );
}

#[test]
fn too_few_rows_is_an_error_naming_the_track() {
    let e = err(&rows("t,x,y", 5, |k| format!("{k},0,0")));
    assert_eq!(
        e.to_string(),
        "dir/a.csv: 5 usable rows, at least 10 needed"
    );
    let e = err(&rows("t,x,y", 12, |k| format!("{k},nan,0")));
    assert!(matches!(e, TrackError::TooFewRows { rows: 0, .. }));
    let text = rows("track,t,x,y", 22, |k| {
        let id = if k < 20 { "a" } else { "b" };
        format!("{id},{k},0,0")
    });
    let e = err(&text);
    assert_eq!(
        e.to_string(),
        "dir/a.csv: 2 usable rows in track \"b\", at least 10 needed"
    );
}

#[test]
fn csv_written_reads_back() {
    let samples: Vec<TrackSample> = (0..20)
        .map(|k| TrackSample {
            t_s: 0.01 * k as f64,
            position_m: [0.1 * k as f64, -0.25],
        })
        .collect();
    let f = ok(&to_csv(&samples, "simulated, not real"));
    assert_eq!(f.source.as_deref(), Some("simulated, not real"));
    for (a, b) in f.tracks[0].samples.iter().zip(&samples) {
        assert!((a.t_s - b.t_s).abs() < 1e-9);
        assert!((a.position_m[0] - b.position_m[0]).abs() < 1e-9);
    }
}

#[test]
fn quoted_fields_indented_comments_and_blank_lines_are_read_as_csv_has_them() {
    // A quoted track id holding the delimiter, quoted numbers, an indented comment and a
    // line of spaces between rows.
    let mut text = String::from("\"time\",\"x\",\"y\",\"track\"\n");
    for k in 0..12 {
        text.push_str(&format!(
            "\"{}\",{},\"0.5\",\"ball, red\"\n",
            0.01 * k as f64,
            k
        ));
        if k == 5 {
            text.push_str("   # the tracker restarted\n   \n");
        }
    }
    let f = ok(&text);
    assert_eq!(f.tracks.len(), 1);
    assert_eq!(f.tracks[0].name, "a.csv#ball, red");
    assert_eq!(f.tracks[0].samples.len(), 12);
    assert_eq!(f.rows, 12);
    // Line numbers count every line, the skipped ones too.
    let bad = text.replacen("11,\"0.5\"", "eleven,\"0.5\"", 1);
    match err(&bad) {
        TrackError::NotANumber { line, value, .. } => {
            assert_eq!((line, value.as_str()), (15, "eleven"))
        }
        e => panic!("{e}"),
    }
}
