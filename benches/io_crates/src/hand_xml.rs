//! The hand-written parser that src/io/xml.rs held before quick-xml (commit 65a6d0b), kept
//! verbatim below this note as the baseline of the XML measurement.
//!
//! A small XML parser, enough for the VTK XML formats: elements, attributes (with the
//! predefined and numeric entities), text, comments, processing instructions and DOCTYPE.
//! Text is kept as raw bytes of the document, so a large inline array is never copied.

use crate::error::{Error, Result};

/// Nesting deeper than this is refused: VTK files use fewer than ten levels, and a limit keeps
/// a hostile file from exhausting the stack when the tree is dropped.
const MAX_DEPTH: usize = 64;

/// An element with its attributes, child elements and its first non-blank text.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Element<'a> {
    pub name: &'a str,
    attributes: Vec<(&'a str, String)>,
    pub children: Vec<Element<'a>>,
    /// The first non-blank text directly inside the element, trimmed.
    pub text: &'a [u8],
}

impl<'a> Element<'a> {
    pub fn attribute(&self, name: &str) -> Option<&str> {
        self.attributes
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, v)| v.as_str())
    }

    pub fn children_named<'s>(
        &'s self,
        name: &'s str,
    ) -> impl Iterator<Item = &'s Element<'a>> + 's {
        self.children.iter().filter(move |c| c.name == name)
    }

    pub fn child(&self, name: &str) -> Option<&Element<'a>> {
        self.children.iter().find(|c| c.name == name)
    }
}

fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).position(|w| w == needle)
}

fn utf8<'a>(bytes: &'a [u8], what: &str) -> Result<&'a str> {
    std::str::from_utf8(bytes).map_err(|_| Error::format(format!("XML {what} is not UTF-8")))
}

fn is_name_end(b: u8) -> bool {
    b.is_ascii_whitespace() || matches!(b, b'/' | b'>' | b'=')
}

/// Replaces `&lt;`, `&gt;`, `&amp;`, `&quot;`, `&apos;` and `&#N;` / `&#xN;`.
fn unescape(raw: &str) -> Result<String> {
    let mut out = String::with_capacity(raw.len());
    let mut rest = raw;
    while let Some(amp) = rest.find('&') {
        out.push_str(&rest[..amp]);
        let semi = rest[amp..]
            .find(';')
            .ok_or_else(|| Error::format("XML entity without ';'"))?;
        let entity = &rest[amp + 1..amp + semi];
        let c = match entity {
            "lt" => '<',
            "gt" => '>',
            "amp" => '&',
            "quot" => '"',
            "apos" => '\'',
            _ => entity
                .strip_prefix("#x")
                .map(|hex| u32::from_str_radix(hex, 16))
                .or_else(|| entity.strip_prefix('#').map(str::parse))
                .and_then(|code| code.ok())
                .and_then(char::from_u32)
                .ok_or_else(|| Error::format(format!("unknown XML entity &{entity};")))?,
        };
        out.push(c);
        rest = &rest[amp + semi + 1..];
    }
    out.push_str(rest);
    Ok(out)
}

/// Parses a start tag at `doc[at] == b'<'`: the element, whether it closes itself, and the
/// position after its `>`.
fn start_tag(doc: &[u8], at: usize) -> Result<(Element<'_>, bool, usize)> {
    let mut pos = at + 1;
    let name_start = pos;
    while pos < doc.len() && !is_name_end(doc[pos]) {
        pos += 1;
    }
    let name = utf8(&doc[name_start..pos], "element name")?;
    if name.is_empty() {
        return Err(Error::format(format!(
            "XML: empty element name at byte {at}"
        )));
    }
    let mut element = Element {
        name,
        attributes: Vec::new(),
        children: Vec::new(),
        text: &[],
    };
    loop {
        while doc.get(pos).is_some_and(u8::is_ascii_whitespace) {
            pos += 1;
        }
        match doc.get(pos) {
            None => return Err(Error::format(format!("XML: <{name}> is not closed by '>'"))),
            Some(b'>') => return Ok((element, false, pos + 1)),
            Some(b'/') if doc.get(pos + 1) == Some(&b'>') => return Ok((element, true, pos + 2)),
            Some(_) => {}
        }
        let attr_start = pos;
        while pos < doc.len() && !is_name_end(doc[pos]) {
            pos += 1;
        }
        let attr = utf8(&doc[attr_start..pos], "attribute name")?;
        while doc.get(pos).is_some_and(u8::is_ascii_whitespace) {
            pos += 1;
        }
        let bad = || {
            Error::format(format!(
                "XML: attribute {attr:?} of <{name}> has no quoted value"
            ))
        };
        if attr.is_empty() || doc.get(pos) != Some(&b'=') {
            return Err(bad());
        }
        pos += 1;
        while doc.get(pos).is_some_and(u8::is_ascii_whitespace) {
            pos += 1;
        }
        let quote = *doc
            .get(pos)
            .filter(|q| matches!(q, b'"' | b'\''))
            .ok_or_else(bad)?;
        let value_len = doc[pos + 1..]
            .iter()
            .position(|&b| b == quote)
            .ok_or_else(bad)?;
        let value = utf8(&doc[pos + 1..pos + 1 + value_len], "attribute value")?;
        element.attributes.push((attr, unescape(value)?));
        pos += value_len + 2;
    }
}

/// Adds a finished element to its parent, or makes it the root.
fn attach<'a>(
    stack: &mut [Element<'a>],
    root: &mut Option<Element<'a>>,
    element: Element<'a>,
) -> Result<()> {
    match stack.last_mut() {
        Some(parent) => parent.children.push(element),
        None if root.is_none() => *root = Some(element),
        None => return Err(Error::format("XML: more than one root element")),
    }
    Ok(())
}

/// Parses a document and returns its root element. With `close_at_end`, elements still open
/// at the end are closed there, for a document cut before binary data.
pub(crate) fn parse(doc: &[u8], close_at_end: bool) -> Result<Element<'_>> {
    let mut stack: Vec<Element> = Vec::new();
    let mut root = None;
    let mut pos = 0;
    while pos < doc.len() {
        if doc[pos] != b'<' {
            let end = doc[pos..]
                .iter()
                .position(|&b| b == b'<')
                .map_or(doc.len(), |n| pos + n);
            let text = doc[pos..end].trim_ascii();
            if !text.is_empty() {
                match stack.last_mut() {
                    Some(parent) if parent.text.is_empty() => parent.text = text,
                    Some(_) => {}
                    None => return Err(Error::format("XML: text outside the root element")),
                }
            }
            pos = end;
            continue;
        }
        let rest = &doc[pos..];
        let skip_to = |end: &[u8], what: &str| {
            find(rest, end)
                .map(|n| pos + n + end.len())
                .ok_or_else(|| Error::format(format!("XML: unterminated {what}")))
        };
        if rest.starts_with(b"<?") {
            pos = skip_to(b"?>", "processing instruction")?;
        } else if rest.starts_with(b"<!--") {
            pos = skip_to(b"-->", "comment")?;
        } else if rest.starts_with(b"<![CDATA[") {
            return Err(Error::format("XML: CDATA sections are not supported"));
        } else if rest.starts_with(b"<!") {
            pos = skip_to(b">", "declaration")?;
        } else if rest.starts_with(b"</") {
            let end = skip_to(b">", "end tag")?;
            let name = utf8(doc[pos + 2..end - 1].trim_ascii(), "element name")?;
            let element = stack
                .pop()
                .filter(|open| open.name == name)
                .ok_or_else(|| Error::format(format!("XML: unexpected </{name}>")))?;
            attach(&mut stack, &mut root, element)?;
            pos = end;
        } else {
            let (element, closed, end) = start_tag(doc, pos)?;
            if closed {
                attach(&mut stack, &mut root, element)?;
            } else if stack.len() >= MAX_DEPTH {
                return Err(Error::format(format!(
                    "XML: elements nested deeper than {MAX_DEPTH} levels"
                )));
            } else {
                stack.push(element);
            }
            pos = end;
        }
    }
    if let Some(open) = stack.last() {
        if !close_at_end {
            return Err(Error::format(format!(
                "XML: <{}> is not closed; the file is truncated",
                open.name
            )));
        }
    }
    while let Some(element) = stack.pop() {
        attach(&mut stack, &mut root, element)?;
    }
    root.ok_or_else(|| Error::format("XML: no root element"))
}
