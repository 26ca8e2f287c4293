//! The serialized FMU state (fmi2SerializeFMUstate / fmi2DeSerializeFMUstate).
//!
//! Byte format, version 1 (all integers little-endian):
//!
//! | bytes | content |
//! |---|---|
//! | 8 | magic `FMI2STAT` |
//! | 4 | format version (1) |
//! | 4 | n = length of the GUID |
//! | n | the GUID of the FMU build that wrote it (a state from another build is refused) |
//! | 8 | m = length of the payload |
//! | m | the payload: UTF-8 JSON of the state |
//!
//! JSON written and parsed by serde_json is not exact for every `f64` (its default float
//! parser can be one ulp off), so every floating-point number is written as `{"$f64":
//! "<16 hex digits of its IEEE-754 bits>"}` and converted back before deserializing:
//! restoring a serialized state replays bit for bit. Encoding checks that the state decodes
//! to itself (a non-finite number, which JSON cannot hold, fails there).

use serde::de::DeserializeOwned;
use serde::Serialize;
use serde_json::{Map, Number, Value};

const MAGIC: &[u8; 8] = b"FMI2STAT";
const VERSION: u32 = 1;
const FLOAT_KEY: &str = "$f64";

/// Why a state cannot be serialized or deserialized; the importer's log gets its text.
#[derive(Debug)]
pub enum SnapshotError {
    Serialize(serde_json::Error),
    /// The state does not decode to itself (a NaN or an infinity, which JSON cannot hold).
    NotExact,
    WrongMagic,
    Version(u32),
    OtherBuild {
        written_by: String,
        guid: String,
    },
    Truncated,
    PayloadTooLarge,
    TrailingBytes(usize),
    Json(serde_json::Error),
    FloatNotText,
    FloatBits {
        hex: String,
        error: std::num::ParseIntError,
    },
    NonFiniteFloat,
}

impl std::fmt::Display for SnapshotError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SnapshotError::Serialize(e) => write!(f, "cannot serialize the state: {e}"),
            SnapshotError::NotExact => write!(
                f,
                "the state does not serialize exactly (does it hold a NaN or an infinity?)"
            ),
            SnapshotError::WrongMagic => write!(
                f,
                "not a serialized FMU state of this FMU (wrong magic bytes)"
            ),
            SnapshotError::Version(v) => write!(
                f,
                "serialized FMU state format version {v} is not supported (this FMU reads {VERSION})"
            ),
            SnapshotError::OtherBuild { written_by, guid } => write!(
                f,
                "the serialized FMU state was written by FMU build {written_by}, this is {guid}"
            ),
            SnapshotError::Truncated => write!(f, "the serialized FMU state is truncated"),
            SnapshotError::PayloadTooLarge => write!(f, "payload length too large"),
            SnapshotError::TrailingBytes(n) => {
                write!(f, "{n} unexpected bytes after the serialized FMU state")
            }
            SnapshotError::Json(e) => write!(f, "corrupt FMU state: {e}"),
            SnapshotError::FloatNotText => write!(f, "corrupt FMU state: float is not a string"),
            SnapshotError::FloatBits { hex, error } => {
                write!(f, "corrupt FMU state: float {hex}: {error}")
            }
            SnapshotError::NonFiniteFloat => write!(f, "corrupt FMU state: non-finite float"),
        }
    }
}

impl std::error::Error for SnapshotError {}

/// Serializes `state` of the FMU build `guid`.
pub fn encode<T: Serialize + DeserializeOwned + PartialEq>(
    state: &T,
    guid: &str,
) -> Result<Vec<u8>, SnapshotError> {
    let mut value = serde_json::to_value(state).map_err(SnapshotError::Serialize)?;
    floats_to_bits(&mut value);
    let payload = serde_json::to_vec(&value).map_err(SnapshotError::Serialize)?;
    let mut bytes = Vec::with_capacity(payload.len() + guid.len() + 24);
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&VERSION.to_le_bytes());
    bytes.extend_from_slice(&(guid.len() as u32).to_le_bytes());
    bytes.extend_from_slice(guid.as_bytes());
    bytes.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    bytes.extend_from_slice(&payload);
    if decode::<T>(&bytes, guid).ok().as_ref() != Some(state) {
        return Err(SnapshotError::NotExact);
    }
    Ok(bytes)
}

/// Deserializes a state written by [`encode`] for the same `guid`.
pub fn decode<T: DeserializeOwned>(bytes: &[u8], guid: &str) -> Result<T, SnapshotError> {
    let mut r = Reader(bytes);
    if r.take(8)? != MAGIC {
        return Err(SnapshotError::WrongMagic);
    }
    let version = u32::from_le_bytes(r.take(4)?.try_into().unwrap());
    if version != VERSION {
        return Err(SnapshotError::Version(version));
    }
    let n = u32::from_le_bytes(r.take(4)?.try_into().unwrap()) as usize;
    let written_by = String::from_utf8_lossy(r.take(n)?).into_owned();
    if written_by != guid {
        return Err(SnapshotError::OtherBuild {
            written_by,
            guid: guid.to_string(),
        });
    }
    let m = u64::from_le_bytes(r.take(8)?.try_into().unwrap());
    let payload = r.take(usize::try_from(m).map_err(|_| SnapshotError::PayloadTooLarge)?)?;
    if !r.0.is_empty() {
        return Err(SnapshotError::TrailingBytes(r.0.len()));
    }
    let mut value: Value = serde_json::from_slice(payload).map_err(SnapshotError::Json)?;
    bits_to_floats(&mut value)?;
    serde_json::from_value(value).map_err(SnapshotError::Json)
}

struct Reader<'a>(&'a [u8]);

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], SnapshotError> {
        if n > self.0.len() {
            return Err(SnapshotError::Truncated);
        }
        let (head, tail) = self.0.split_at(n);
        self.0 = tail;
        Ok(head)
    }
}

fn floats_to_bits(value: &mut Value) {
    match value {
        Value::Number(n) if n.is_f64() => {
            let bits = n.as_f64().unwrap().to_bits();
            let mut map = Map::new();
            map.insert(FLOAT_KEY.into(), Value::String(format!("{bits:016x}")));
            *value = Value::Object(map);
        }
        Value::Array(items) => items.iter_mut().for_each(floats_to_bits),
        Value::Object(map) => map.values_mut().for_each(floats_to_bits),
        _ => {}
    }
}

fn bits_to_floats(value: &mut Value) -> Result<(), SnapshotError> {
    match value {
        Value::Object(map) if map.len() == 1 && map.contains_key(FLOAT_KEY) => {
            let hex = map[FLOAT_KEY].as_str().ok_or(SnapshotError::FloatNotText)?;
            let bits = u64::from_str_radix(hex, 16).map_err(|error| SnapshotError::FloatBits {
                hex: hex.to_string(),
                error,
            })?;
            let number =
                Number::from_f64(f64::from_bits(bits)).ok_or(SnapshotError::NonFiniteFloat)?;
            *value = Value::Number(number);
        }
        Value::Array(items) => items.iter_mut().try_for_each(bits_to_floats)?,
        Value::Object(map) => map.values_mut().try_for_each(bits_to_floats)?,
        _ => {}
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, PartialEq, serde::Serialize, serde::Deserialize)]
    struct S {
        a: f64,
        b: Vec<f64>,
        n: u64,
        name: String,
    }

    fn sample() -> S {
        // 0.1 + 0.2 and the subnormal are values whose shortest decimal text can parse one ulp off.
        S {
            a: 0.1 + 0.2,
            b: vec![5e-324, 1.0 / 3.0, -0.0, 123456.789e-300],
            n: u64::MAX,
            name: "x".into(),
        }
    }

    #[test]
    fn round_trip_is_bit_exact() {
        let bytes = encode(&sample(), "{g}").unwrap();
        let back: S = decode(&bytes, "{g}").unwrap();
        assert_eq!(back.a.to_bits(), sample().a.to_bits());
        assert_eq!(back.b[2].to_bits(), (-0.0f64).to_bits());
        assert_eq!(back, sample());
    }

    #[test]
    fn corrupt_or_foreign_bytes_are_refused() {
        let bytes = encode(&sample(), "{g}").unwrap();
        assert!(decode::<S>(&bytes, "{other}")
            .unwrap_err()
            .to_string()
            .contains("{g}"));
        assert!(decode::<S>(&bytes[..bytes.len() - 1], "{g}")
            .unwrap_err()
            .to_string()
            .contains("truncated"));
        assert!(decode::<S>(b"NOTSTATE", "{g}")
            .unwrap_err()
            .to_string()
            .contains("magic"));
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(decode::<S>(&longer, "{g}")
            .unwrap_err()
            .to_string()
            .contains("unexpected bytes"));
        let mut v2 = bytes;
        v2[8] = 2;
        assert!(decode::<S>(&v2, "{g}")
            .unwrap_err()
            .to_string()
            .contains("version 2"));
    }

    #[test]
    fn non_finite_state_is_refused() {
        let s = S {
            a: f64::NAN,
            ..sample()
        };
        assert!(encode(&s, "{g}").unwrap_err().to_string().contains("NaN"));
    }
}
