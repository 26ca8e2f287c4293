//! fmuResourceLocation: a URI (`file:///C:/x%20y/resources`) turned into a path.

/// The percent-decoded path of a `file:` URI (`file:///p`, `file:/p`, `file://localhost/p`;
/// `/C:/p` becomes `C:/p`), or the decoded text of any other URI.
pub fn decode_resource_location(uri: &str) -> String {
    let path = uri
        .strip_prefix("file://localhost/")
        .or_else(|| uri.strip_prefix("file:///"))
        .map(|rest| format!("/{rest}"))
        .or_else(|| uri.strip_prefix("file:").map(str::to_string))
        .unwrap_or_else(|| uri.to_string());
    let decoded = percent_decode(&path);
    let bytes = decoded.as_bytes();
    let is_drive =
        bytes.len() >= 3 && bytes[0] == b'/' && bytes[1].is_ascii_alphabetic() && bytes[2] == b':';
    if is_drive {
        decoded[1..].to_string()
    } else {
        decoded
    }
}

/// `%XX` escapes decoded to bytes (an invalid escape is kept as it is), read as UTF-8.
fn percent_decode(s: &str) -> String {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = bytes
            .get(i + 1..i + 3)
            .filter(|h| h.iter().all(u8::is_ascii_hexdigit))
            .and_then(|h| std::str::from_utf8(h).ok());
        match hex.and_then(|h| u8::from_str_radix(h, 16).ok()) {
            Some(b) if bytes[i] == b'%' => {
                out.push(b);
                i += 3;
            }
            _ => {
                out.push(bytes[i]);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

#[cfg(test)]
mod tests {
    use super::decode_resource_location as d;

    #[test]
    fn file_uris_become_decoded_paths() {
        assert_eq!(d("file:///tmp/my%20fmu/resources"), "/tmp/my fmu/resources");
        assert_eq!(d("file:/tmp/a%7Bb%7D"), "/tmp/a{b}");
        assert_eq!(d("file://localhost/tmp/x"), "/tmp/x");
        assert_eq!(d("file:///C:/Users/A%C3%A9/r"), "C:/Users/Aé/r");
        assert_eq!(d("file:///tmp/100%"), "/tmp/100%");
        assert_eq!(d("file:///tmp/%zz%+1"), "/tmp/%zz%+1");
        assert_eq!(d("http://host/a%20b"), "http://host/a b");
    }
}
