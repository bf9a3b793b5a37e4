//! How typed values become the bytes of a run file and back ([`Format`]), and the shared
//! pieces of the formats: JSON and TOML documents with a format version, CSV tables of typed
//! rows ([`Rows`]) and of named numeric columns ([`Table`]), and the number formats of CSV
//! cells ([`num`]).

use serde::Serialize;
use serde::de::DeserializeOwned;

/// A file format: how a value is written and read back. `decode(encode(v)) == v` for every
/// value (numbers included) unless a field's documentation states a fixed precision.
pub trait Format: Sized + Send + Sync + 'static {
    /// Whether `decode(encode(v)) == v` holds for every value. A format with a stated fixed
    /// precision is not exact; [`crate::RunDir::store`] then keeps the value as a reader of the
    /// file gets it (decoded from the bytes written), so that a value is the same from memory
    /// and from the file.
    const EXACT: bool = true;

    /// The bytes of the file.
    fn encode(&self) -> Result<Vec<u8>, String>;
    /// The value of a file's bytes; the error says what is wrong, in words.
    fn decode(bytes: &[u8]) -> Result<Self, String>;
}

/// Pretty JSON of a value, fields in declaration order.
pub fn json<T: Serialize>(value: &T) -> Result<Vec<u8>, String> {
    serde_json::to_vec_pretty(value).map_err(|e| e.to_string())
}

/// Pretty JSON of a value with the keys of every object sorted (the layout of files written
/// through `serde_json::Value`).
pub fn json_sorted<T: Serialize>(value: &T) -> Result<Vec<u8>, String> {
    let v = serde_json::to_value(value).map_err(|e| e.to_string())?;
    json(&v)
}

/// A JSON document parsed into `T` (floats exactly, `float_roundtrip`).
pub fn from_json<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, String> {
    serde_json::from_slice(bytes).map_err(|e| e.to_string())
}

/// A TOML document parsed into `T`.
pub fn from_toml<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, String> {
    let text = std::str::from_utf8(bytes).map_err(|e| format!("not UTF-8 text: {e}"))?;
    toml::from_str(text).map_err(|e| e.to_string())
}

/// `Ok` when a file's `version` is the one this flexstage reads.
pub fn check_version(found: u32, expected: u32) -> Result<(), String> {
    if found == expected {
        Ok(())
    } else {
        Err(format!(
            "format version {found} (this flexstage reads version {expected})"
        ))
    }
}

/// One row type of a CSV file: its header, in column order (the field names of its serde
/// form).
pub trait Row: Serialize + DeserializeOwned + Send + Sync + 'static {
    /// The header row.
    const HEADER: &'static [&'static str];
    /// Whether every field reads back exactly (no stated fixed precision).
    const EXACT: bool = true;
}

/// A CSV file of typed rows, written and read by the `csv` crate (quoting included); the
/// header must be [`Row::HEADER`] exactly and every row must have its fields.
#[derive(Debug, Clone, PartialEq)]
pub struct Rows<T>(pub Vec<T>);

impl<T: Row> Format for Rows<T> {
    const EXACT: bool = T::EXACT;

    fn encode(&self) -> Result<Vec<u8>, String> {
        let mut w = csv::WriterBuilder::new()
            .has_headers(false)
            .from_writer(Vec::new());
        w.write_record(T::HEADER).map_err(|e| e.to_string())?;
        for r in &self.0 {
            w.serialize(r).map_err(|e| e.to_string())?;
        }
        w.into_inner().map_err(|e| e.to_string())
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let mut r = csv::ReaderBuilder::new().from_reader(bytes);
        let header = r.headers().map_err(|e| e.to_string())?.clone();
        if header.iter().ne(T::HEADER.iter().copied()) {
            return Err(format!(
                "header {:?}, expected {:?}",
                header.iter().collect::<Vec<_>>(),
                T::HEADER
            ));
        }
        let rows = r
            .deserialize()
            .enumerate()
            .map(|(i, row)| row.map_err(|e| format!("line {}: {e}", i + 2)))
            .collect::<Result<Vec<T>, String>>()?;
        Ok(Rows(rows))
    }
}

/// A CSV file of named numeric columns (time series, histories, sampled maps): one header
/// row, then one row per sample in Rust's shortest round-trip number form. Columns of
/// unequal length are padded with empty cells, read back as NaN.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// Column names.
    pub header: Vec<String>,
    /// Columns, one per name.
    pub columns: Vec<Vec<f64>>,
}

impl Table {
    /// A table of the given columns.
    pub fn new(header: &[&str], columns: Vec<Vec<f64>>) -> Table {
        assert_eq!(header.len(), columns.len(), "one header per column");
        Table {
            header: header.iter().map(|h| h.to_string()).collect(),
            columns,
        }
    }

    /// A table of borrowed columns (copied).
    pub fn of(header: &[&str], columns: &[&[f64]]) -> Table {
        Table::new(header, columns.iter().map(|c| c.to_vec()).collect())
    }

    /// The column named `name`.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        let i = self.header.iter().position(|h| h == name)?;
        Some(&self.columns[i])
    }

    /// The columns named `names`, in that order; the error names the first one missing.
    pub fn columns(&self, names: &[&str]) -> Result<Vec<&[f64]>, String> {
        names
            .iter()
            .map(|n| {
                self.column(n)
                    .ok_or_else(|| format!("no column {n:?} (columns: {})", self.header.join(",")))
            })
            .collect()
    }

    /// Pairs of two columns (x, y).
    pub fn pairs(&self, x: &str, y: &str) -> Result<Vec<(f64, f64)>, String> {
        let c = self.columns(&[x, y])?;
        Ok(c[0].iter().copied().zip(c[1].iter().copied()).collect())
    }
}

impl Table {
    /// The CSV bytes ([`Format::encode`], which cannot fail for a table).
    pub fn to_csv(&self) -> Vec<u8> {
        let rows = self.columns.iter().map(Vec::len).max().unwrap_or(0);
        let mut out = self.header.join(",");
        out.push('\n');
        for r in 0..rows {
            for (j, c) in self.columns.iter().enumerate() {
                if j > 0 {
                    out.push(',');
                }
                if let Some(v) = c.get(r) {
                    out.push_str(&v.to_string());
                }
            }
            out.push('\n');
        }
        out.into_bytes()
    }
}

impl Format for Table {
    fn encode(&self) -> Result<Vec<u8>, String> {
        Ok(self.to_csv())
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let mut r = csv::ReaderBuilder::new().from_reader(bytes);
        let header: Vec<String> = r
            .headers()
            .map_err(|e| e.to_string())?
            .iter()
            .map(str::to_string)
            .collect();
        let mut columns = vec![Vec::new(); header.len()];
        for (i, rec) in r.records().enumerate() {
            let rec = rec.map_err(|e| format!("line {}: {e}", i + 2))?;
            for (j, cell) in rec.iter().enumerate() {
                columns[j].push(if cell.is_empty() {
                    f64::NAN
                } else {
                    cell.parse().map_err(|_| {
                        format!(
                            "line {}, column {}: {cell:?} is not a number",
                            i + 2,
                            header[j]
                        )
                    })?
                });
            }
        }
        Ok(Table { header, columns })
    }
}

/// Number formats of CSV cells (serde `serialize_with`); each reads back with Rust's `f64`
/// parser. A fixed precision is the file's stated precision, not a round trip.
pub mod num {
    use serde::Serializer;

    /// Rust's shortest round-trip form (`Display`: `0.000001`, `1`, `NaN`).
    pub fn display<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(v)
    }

    /// The shortest round-trip form with an exponent (`LowerExp`: `1e-6`, `2.5e3`).
    pub fn exp<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(&format_args!("{v:e}"))
    }

    /// [`exp`], an empty cell for `None`.
    pub fn opt_exp<S: Serializer>(v: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
        match v {
            Some(v) => exp(v, s),
            None => s.serialize_str(""),
        }
    }

    macro_rules! fixed {
        ($($name:ident, $opt:ident, $digits:literal;)*) => {$(
            #[doc = concat!("Fixed point with ", stringify!($digits), " decimals.")]
            pub fn $name<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
                s.collect_str(&format_args!("{v:.*}", $digits))
            }
            #[doc = concat!("Fixed point with ", stringify!($digits), " decimals, an empty cell for `None`.")]
            pub fn $opt<S: Serializer>(v: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
                match v {
                    Some(v) => $name(v, s),
                    None => s.serialize_str(""),
                }
            }
        )*};
    }

    fixed! {
        fixed0, opt_fixed0, 0;
        fixed1, opt_fixed1, 1;
        fixed2, opt_fixed2, 2;
        fixed3, opt_fixed3, 3;
        fixed4, opt_fixed4, 4;
        fixed5, opt_fixed5, 5;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_round_trip_exact_values_and_pad_with_nan() {
        let t = Table::of(&["a", "b"], &[&[0.1, 1e-9, -3.0], &[2.5]]);
        let bytes = t.encode().unwrap();
        assert_eq!(
            String::from_utf8(bytes.clone()).unwrap(),
            "a,b\n0.1,2.5\n0.000000001,\n-3,\n"
        );
        let back = Table::decode(&bytes).unwrap();
        assert_eq!(back.column("a").unwrap(), [0.1, 1e-9, -3.0]);
        assert_eq!(back.column("b").unwrap()[0], 2.5);
        assert!(
            back.column("b").unwrap()[1].is_nan(),
            "padding reads as NaN"
        );
        assert!(back.columns(&["c"]).unwrap_err().contains("\"c\""));
        let e = Table::decode(b"a,b\n1,2\n3\n").unwrap_err();
        assert!(e.contains("line 3"), "a short row is refused: {e}");
        let e = Table::decode(b"a,b\n1,x\n").unwrap_err();
        assert!(e.contains("line 2") && e.contains("column b"), "{e}");
    }

    #[derive(Debug, PartialEq, serde::Serialize, serde::Deserialize)]
    struct R {
        name: String,
        #[serde(serialize_with = "num::fixed2")]
        v: f64,
        #[serde(serialize_with = "num::opt_exp")]
        w: Option<f64>,
    }
    impl Row for R {
        const HEADER: &'static [&'static str] = &["name", "v", "w"];
        const EXACT: bool = false;
    }

    #[test]
    fn rows_keep_their_stated_precision_and_refuse_another_header() {
        let rows = Rows(vec![
            R {
                name: "a,b".into(),
                v: 6.0,
                w: Some(1e-6),
            },
            R {
                name: "c".into(),
                v: 0.125,
                w: None,
            },
        ]);
        let bytes = rows.encode().unwrap();
        assert_eq!(
            String::from_utf8(bytes.clone()).unwrap(),
            "name,v,w\n\"a,b\",6.00,1e-6\nc,0.12,\n"
        );
        let back = Rows::<R>::decode(&bytes).unwrap();
        assert_eq!(back.0[0].w, Some(1e-6));
        assert_eq!(back.0[1].w, None);
        assert_eq!(back.0[1].v, 0.12, "the file's precision");
        assert!(Rows::<R>::decode(b"name,v\nc,1\n").is_err());
        assert!(Rows::<R>::decode(b"name,v,w\nc,1,2,3\n").is_err());
    }
}
