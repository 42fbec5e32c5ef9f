//! Matrix Market (`coordinate`, `real` or `integer`, `general` or `symmetric`): the text format
//! scipy (`scipy.io.mmread`) and MATLAB (`mmread.m`) read and write.
//!
//! ```text
//! %%MatrixMarket matrix coordinate real symmetric
//! % a comment
//! 3 3 5                                      rows, columns, entries written
//! 1 1 2.0000000000000000e0                   row, column (1-based), value
//! 2 1 -1.0000000000000000e0
//! ...
//! ```
//!
//! A symmetric matrix (equal to its transpose bit for bit) is written as its lower triangle,
//! column by column; any other as `general` with every stored entry. Values carry 17
//! significant digits, which identify an IEEE double uniquely, so readers get the exact bits
//! back.

use std::fmt::Write;

use crate::Error;
use crate::csc::CscMatrix;

/// Checks the compressed-column structure, so that reading it cannot index out of bounds.
fn check_structure(matrix: &CscMatrix) -> Result<(), String> {
    let n_entries = matrix.row_idx.len();
    if matrix.col_ptr.len() != matrix.n_cols + 1
        || matrix.col_ptr.first() != Some(&0)
        || matrix.col_ptr.last() != Some(&n_entries)
        || matrix.values.len() != n_entries
        || matrix.col_ptr.windows(2).any(|pair| pair[0] > pair[1])
    {
        return Err("malformed compressed-column structure".to_string());
    }
    for col in 0..matrix.n_cols {
        let rows = &matrix.row_idx[matrix.col_ptr[col]..matrix.col_ptr[col + 1]];
        if rows.windows(2).any(|pair| pair[0] >= pair[1])
            || rows.last().is_some_and(|row| *row >= matrix.n_rows)
        {
            return Err(format!(
                "column {col} has row indices out of order or out of range"
            ));
        }
    }
    Ok(())
}

/// Whether the matrix equals its transpose bit for bit (so its lower triangle says it all).
fn is_symmetric(matrix: &CscMatrix) -> bool {
    if matrix.n_rows != matrix.n_cols {
        return false;
    }
    (0..matrix.n_cols).all(|col| {
        (matrix.col_ptr[col]..matrix.col_ptr[col + 1]).all(|entry| {
            let row = matrix.row_idx[entry];
            let mirror = &matrix.row_idx[matrix.col_ptr[row]..matrix.col_ptr[row + 1]];
            mirror.binary_search(&col).is_ok_and(|offset| {
                let value = matrix.values[matrix.col_ptr[row] + offset];
                value.to_bits() == matrix.values[entry].to_bits()
            })
        })
    })
}

/// The Matrix Market text of `matrix`: `symmetric` (lower triangle) when it equals its
/// transpose, `general` otherwise; `comment` goes on `%` lines after the header.
pub fn write_matrix_market(matrix: &CscMatrix, comment: &str) -> Result<String, Error> {
    write_text(matrix, comment).map_err(Error::InvalidInput)
}

fn write_text(matrix: &CscMatrix, comment: &str) -> Result<String, String> {
    check_structure(matrix)?;
    let symmetric = is_symmetric(matrix);
    let written = |row: usize, col: usize| !symmetric || row >= col;
    let n_written = (0..matrix.n_cols)
        .map(|col| {
            matrix.row_idx[matrix.col_ptr[col]..matrix.col_ptr[col + 1]]
                .iter()
                .filter(|row| written(**row, col))
                .count()
        })
        .sum::<usize>();
    // About 40 bytes per entry line.
    let mut text = String::with_capacity(128 + 40 * n_written);
    let symmetry = if symmetric { "symmetric" } else { "general" };
    // Writing to a String cannot fail.
    let _ = writeln!(text, "%%MatrixMarket matrix coordinate real {symmetry}");
    for line in comment.lines() {
        let _ = writeln!(text, "% {line}");
    }
    let _ = writeln!(text, "{} {} {n_written}", matrix.n_rows, matrix.n_cols);
    for col in 0..matrix.n_cols {
        for entry in matrix.col_ptr[col]..matrix.col_ptr[col + 1] {
            let row = matrix.row_idx[entry];
            if written(row, col) {
                // 1 digit before the point and 16 after: 17 significant digits.
                let _ = writeln!(
                    text,
                    "{} {} {:.16e}",
                    row + 1,
                    col + 1,
                    matrix.values[entry]
                );
            }
        }
    }
    Ok(text)
}

/// Reads a Matrix Market `coordinate` matrix, `real` or `integer`, `general` or `symmetric`
/// (lower triangle, mirrored on reading). Errors name the 1-based line. Entries given twice
/// are an error rather than summed, so that what is read is what was meant.
pub fn read_matrix_market(text: &str) -> Result<CscMatrix, Error> {
    read_text(text).map_err(Error::Parse)
}

fn read_text(text: &str) -> Result<CscMatrix, String> {
    let mut lines = text.lines().enumerate().map(|(idx, line)| (idx + 1, line));
    let (_, header) = lines
        .next()
        .ok_or_else(|| "empty file: expected a %%MatrixMarket header".to_string())?;
    let symmetric = parse_header(header).map_err(|err| format!("line 1: {err}"))?;

    // Comments and blank lines may come before the size line and between entries.
    let mut data = lines.filter(|(_, line)| {
        let line = line.trim();
        !line.is_empty() && !line.starts_with('%')
    });
    let (size_line, size) = data
        .next()
        .ok_or_else(|| "no size line `rows columns entries`".to_string())?;
    let fields: Vec<&str> = size.split_whitespace().collect();
    let [n_rows, n_cols, n_entries] = fields[..] else {
        return Err(format!(
            "line {size_line}: expected `rows columns entries`, found `{}`",
            size.trim()
        ));
    };
    let parse_count = |token: &str, what: &str| {
        token
            .parse::<usize>()
            .map_err(|_| format!("line {size_line}: {what} `{token}` is not a count"))
    };
    let n_rows = parse_count(n_rows, "rows")?;
    let n_cols = parse_count(n_cols, "columns")?;
    let n_entries = parse_count(n_entries, "entries")?;
    if symmetric && n_rows != n_cols {
        return Err(format!(
            "line {size_line}: a symmetric matrix must be square, this one is {n_rows} x {n_cols}"
        ));
    }

    // (column, row, value, line), both triangles for a symmetric file.
    let mut triplets: Vec<(usize, usize, f64, usize)> =
        Vec::with_capacity(if symmetric { 2 * n_entries } else { n_entries });
    let mut n_read = 0;
    for (line_no, line) in data {
        if n_read == n_entries {
            return Err(format!(
                "line {line_no}: more entries than the {n_entries} announced on line {size_line}"
            ));
        }
        let fields: Vec<&str> = line.split_whitespace().collect();
        let [row, col, value] = fields[..] else {
            return Err(format!(
                "line {line_no}: expected `row column value`, found `{}`",
                line.trim()
            ));
        };
        let index = |token: &str, size: usize, what: &str| match token.parse::<usize>() {
            Ok(index) if (1..=size).contains(&index) => Ok(index - 1),
            _ => Err(format!(
                "line {line_no}: {what} `{token}` is not in 1..={size}"
            )),
        };
        let row = index(row, n_rows, "row")?;
        let col = index(col, n_cols, "column")?;
        let value: f64 = value
            .parse()
            .map_err(|_| format!("line {line_no}: value `{value}` is not a number"))?;
        if symmetric && row < col {
            return Err(format!(
                "line {line_no}: entry ({}, {}) is above the diagonal of a symmetric matrix, which stores its lower triangle",
                row + 1,
                col + 1
            ));
        }
        triplets.push((col, row, value, line_no));
        if symmetric && row != col {
            triplets.push((row, col, value, line_no));
        }
        n_read += 1;
    }
    if n_read != n_entries {
        return Err(format!(
            "line {size_line} announces {n_entries} entries, the file has {n_read}"
        ));
    }

    triplets.sort_by_key(|&(col, row, _, line)| (col, row, line));
    if let Some(pair) = triplets
        .windows(2)
        .find(|pair| (pair[0].0, pair[0].1) == (pair[1].0, pair[1].1))
    {
        let (col, row, _, first_line) = pair[0];
        return Err(format!(
            "line {}: entry ({}, {}) was already given on line {first_line}",
            pair[1].3,
            row + 1,
            col + 1
        ));
    }
    Ok(CscMatrix::from_triplets(
        n_rows,
        n_cols,
        triplets
            .into_iter()
            .map(|(col, row, value, _)| (row, col, value))
            .collect(),
    ))
}

/// Parses `%%MatrixMarket matrix coordinate real symmetric`; returns whether it is symmetric.
fn parse_header(header: &str) -> Result<bool, String> {
    let fields: Vec<String> = header
        .split_whitespace()
        .map(str::to_ascii_lowercase)
        .collect();
    let fields: Vec<&str> = fields.iter().map(String::as_str).collect();
    let ["%%matrixmarket", object, format, field, symmetry] = fields[..] else {
        return Err(format!(
            "expected `%%MatrixMarket matrix coordinate real general|symmetric`, found `{}`",
            header.trim()
        ));
    };
    if object != "matrix" {
        return Err(format!("object `{object}` is not supported, only `matrix`"));
    }
    if format != "coordinate" {
        return Err(format!(
            "format `{format}` is not supported, only sparse `coordinate`"
        ));
    }
    if field != "real" && field != "integer" {
        return Err(format!(
            "field `{field}` is not supported, only `real` and `integer`"
        ));
    }
    match symmetry {
        "general" => Ok(false),
        "symmetric" => Ok(true),
        other => Err(format!(
            "symmetry `{other}` is not supported, only `general` and `symmetric`"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A CSC matrix from dense rows, keeping the non-zeros.
    fn csc(dense: &[&[f64]]) -> CscMatrix {
        let n_rows = dense.len();
        let n_cols = dense[0].len();
        let mut matrix = CscMatrix {
            n_rows,
            n_cols,
            col_ptr: vec![0],
            ..CscMatrix::default()
        };
        for col in 0..n_cols {
            for (row, values) in dense.iter().enumerate() {
                if values[col] != 0.0 {
                    matrix.row_idx.push(row);
                    matrix.values.push(values[col]);
                }
            }
            matrix.col_ptr.push(matrix.row_idx.len());
        }
        matrix
    }

    /// Values whose shortest decimal forms need all 17 digits, or test the exponent range.
    const AWKWARD: [f64; 6] = [
        0.1,
        1.0 / 3.0,
        -2.0e-310, // subnormal
        1.7976931348623157e308,
        -123456.78901234567,
        std::f64::consts::PI * 1e-20,
    ];

    #[test]
    fn symmetric_matrix_round_trips_to_the_bit() {
        let [a, b, c, d, e, f] = AWKWARD;
        let matrix = csc(&[
            &[a, b, 0.0, c],
            &[b, d, e, 0.0],
            &[0.0, e, f, 0.0],
            &[c, 0.0, 0.0, 1.0],
        ]);
        let text = write_matrix_market(&matrix, "a test\nof two lines").unwrap();
        let mut lines = text.lines();
        assert_eq!(
            lines.next(),
            Some("%%MatrixMarket matrix coordinate real symmetric")
        );
        assert_eq!(lines.next(), Some("% a test"));
        assert_eq!(lines.next(), Some("% of two lines"));
        // 10 stored entries: 4 on the diagonal, 3 below it.
        assert_eq!(lines.next(), Some("4 4 7"));
        assert_eq!(lines.next(), Some("1 1 1.0000000000000001e-1"));
        let read = read_matrix_market(&text).unwrap();
        assert_eq!(read.col_ptr, matrix.col_ptr);
        assert_eq!(read.row_idx, matrix.row_idx);
        let bits = |values: &[f64]| values.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&read.values), bits(&matrix.values));
    }

    #[test]
    fn unsymmetric_matrix_is_written_general() {
        let [a, b, c, ..] = AWKWARD;
        // Equal patterns, values that differ in the last bit.
        let b_next = f64::from_bits(b.to_bits() + 1);
        let matrix = csc(&[&[a, b, 0.0], &[b_next, c, 0.0], &[0.0, 0.0, 1.0]]);
        let text = write_matrix_market(&matrix, "").unwrap();
        assert!(text.starts_with("%%MatrixMarket matrix coordinate real general\n"));
        let read = read_matrix_market(&text).unwrap();
        assert_eq!(read, matrix);
        let rectangular = csc(&[&[a, b, 0.0], &[b, c, 0.0]]);
        let text = write_matrix_market(&rectangular, "").unwrap();
        assert!(text.contains("general\n2 3 4\n"), "{text}");
        assert_eq!(read_matrix_market(&text).unwrap(), rectangular);
    }

    /// Reading `text` fails with a message containing `expected`.
    fn check_error(text: &str, expected: &str) {
        let err = read_matrix_market(text).expect_err("the text should be refused");
        let err = err.to_string();
        assert!(err.contains(expected), "`{err}` lacks `{expected}`");
    }

    #[test]
    fn reader_names_the_line_of_each_error() {
        let header = "%%MatrixMarket matrix coordinate real symmetric\n";
        check_error("", "empty file");
        check_error(
            "%%MatrixMarket matrix array real general\n2 2\n",
            "line 1: format `array`",
        );
        check_error(
            "%%MatrixMarket matrix coordinate complex general\n",
            "line 1: field `complex`",
        );
        check_error(
            "%%MatrixMarket matrix coordinate real hermitian\n",
            "line 1: symmetry `hermitian`",
        );
        check_error(
            "%MatrixMarket matrix coordinate real general\n",
            "line 1: expected",
        );
        check_error(
            &format!("{header}2 3 1\n"),
            "line 2: a symmetric matrix must be square",
        );
        check_error(
            &format!("{header}% c\n2 2 1\n1 3 1.0\n"),
            "line 4: column `3` is not in 1..=2",
        );
        check_error(
            &format!("{header}2 2 1\n1 2 1.0\n"),
            "line 3: entry (1, 2) is above the diagonal",
        );
        check_error(
            &format!("{header}2 2 1\n1 1 one\n"),
            "line 3: value `one` is not a number",
        );
        check_error(
            &format!("{header}2 2 1\n1 1\n"),
            "line 3: expected `row column value`",
        );
        check_error(
            &format!("{header}2 2 2\n1 1 1.0\n"),
            "line 2 announces 2 entries, the file has 1",
        );
        check_error(
            &format!("{header}2 2 1\n1 1 1.0\n2 2 1.0\n"),
            "line 4: more entries",
        );
        check_error(
            &format!("{header}2 2 2\n2 1 1.0\n\n2 1 2.0\n"),
            "line 5: entry (2, 1) was already given on line 3",
        );
        let read = read_matrix_market(
            "%%MatrixMarket matrix coordinate integer general\n% comment\n\n2 2 1\n2 1 7\n",
        )
        .unwrap();
        assert_eq!(read, csc(&[&[0.0, 0.0], &[7.0, 0.0]]));
    }
}
