//! The element tree of an XML document, enough for the VTK XML formats, built from the events
//! of quick-xml's reader (XML 1.0: elements, attributes with the predefined and numeric
//! entities, text, comments, processing instructions and DOCTYPE; CDATA is refused, as VTK
//! never writes it). Names, text and most attribute values borrow from the document, so a
//! large inline array is never copied.
//!
//! quick-xml replaced a hand-written parser: on VTK's files with inline arrays it builds the
//! same tree in 0.03 to 0.13 of the time (the aorta as an ascii .vti, 21 MB: 2.1 ms against
//! 15.8 ms), where appended data leaves only a few hundred bytes of XML both take a few
//! microseconds (BENCHMARKS.md, "io: our readers against the crates"), and its tag, attribute
//! and end-tag checks are maintained by others. The tree, the depth limit and stopping before
//! appended binary data stay ours.

use std::borrow::Cow;

use quick_xml::events::attributes::Attributes;
use quick_xml::events::{BytesStart, Event};
use quick_xml::{Reader, XmlVersion};

use crate::error::{Error, Result};

/// Nesting deeper than this is refused: VTK files use fewer than ten levels, and a limit keeps
/// a hostile file from exhausting the stack when the tree is dropped.
const MAX_DEPTH: usize = 64;

/// An element with its attributes, child elements and its first non-blank text.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Element<'a> {
    pub name: &'a str,
    attributes: Vec<(&'a str, Cow<'a, str>)>,
    pub children: Vec<Element<'a>>,
    /// The first non-blank text directly inside the element, trimmed, as it stands in the
    /// document (entities in it are not replaced).
    pub text: &'a [u8],
}

impl<'a> Element<'a> {
    pub fn attribute(&self, name: &str) -> Option<&str> {
        self.attributes
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, v)| v.as_ref())
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

/// A parsed document.
#[derive(Debug)]
pub(crate) struct Document<'a> {
    pub root: Element<'a>,
    /// When parsing stopped at an element named `stop_at`: that element (without children or
    /// text) and every byte after its start tag, unparsed.
    pub rest: Option<(Element<'a>, &'a [u8])>,
}

fn utf8<'a>(bytes: &'a [u8], what: &str, at: u64) -> Result<&'a str> {
    std::str::from_utf8(bytes)
        .map_err(|_| Error::format(format!("XML at byte {at}: the {what} is not UTF-8")))
}

/// The element of the start tag at byte `at` of `doc`, its attribute values unescaped and
/// normalised.
fn element<'a>(doc: &'a [u8], tag: &BytesStart, at: u64) -> Result<Element<'a>> {
    let name_len = tag.name().as_ref().len();
    // The tag's text as a slice of the document itself (it follows the '<'), so that the
    // element can borrow from the document rather than from the event.
    let start = at as usize + 1;
    let raw = doc
        .get(start..start + tag.len())
        .filter(|raw| *raw == &tag[..])
        .ok_or_else(|| Error::format(format!("XML at byte {at}: a tag out of place")))?;
    let raw = utf8(raw, "tag", at)?;
    let name = &raw[..name_len];
    if name.is_empty() {
        return Err(Error::format(format!(
            "XML at byte {at}: empty element name"
        )));
    }
    let bad =
        |e: &dyn std::fmt::Display| Error::format(format!("XML at byte {at}: in <{name}>: {e}"));
    let mut attributes = Vec::new();
    for attribute in Attributes::new(raw, name_len) {
        let attribute = attribute.map_err(|e| bad(&e))?;
        let key = utf8(attribute.key.into_inner(), "attribute name", at)?;
        let value = attribute
            .normalized_value(XmlVersion::Implicit1_0)
            .map_err(|e| bad(&format!("attribute {key:?}: {e}")))?;
        attributes.push((key, value));
    }
    Ok(Element {
        name,
        attributes,
        children: Vec::new(),
        text: &[],
    })
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

/// Parses `doc` up to its end, or up to the start tag of the first element named `stop_at`
/// (the elements still open there are closed, as for a document cut before binary data).
pub(crate) fn parse<'a>(doc: &'a [u8], stop_at: Option<&str>) -> Result<Document<'a>> {
    let mut reader = Reader::from_reader(doc);
    let mut stack: Vec<Element> = Vec::new();
    let mut root = None;
    // Text and entity references in a row, as one span of the document: a run of them is one
    // text, as if entities were kept in it.
    let mut text: Option<(usize, usize)> = None;
    let mut rest = None;
    loop {
        let at = reader.buffer_position();
        let event = reader
            .read_event()
            .map_err(|e| Error::format(format!("XML at byte {}: {e}", reader.error_position())))?;
        let end = reader.buffer_position() as usize;
        if matches!(event, Event::Text(_) | Event::GeneralRef(_)) {
            let start = text.map_or(at as usize, |(start, _)| start);
            text = Some((start, end));
            continue;
        }
        if let Some((start, end)) = text.take() {
            let text = doc[start..end].trim_ascii();
            if !text.is_empty() {
                match stack.last_mut() {
                    Some(parent) if parent.text.is_empty() => parent.text = text,
                    Some(_) => {}
                    None => {
                        return Err(Error::format(format!(
                            "XML at byte {start}: text outside the root element"
                        )))
                    }
                }
            }
        }
        match event {
            Event::Start(tag) | Event::Empty(tag)
                if stop_at.is_some_and(|name| name.as_bytes() == tag.name().as_ref()) =>
            {
                rest = Some((element(doc, &tag, at)?, &doc[end..]));
                break;
            }
            Event::Start(tag) => {
                if stack.len() >= MAX_DEPTH {
                    return Err(Error::format(format!(
                        "XML at byte {at}: elements nested deeper than {MAX_DEPTH} levels"
                    )));
                }
                stack.push(element(doc, &tag, at)?);
            }
            Event::Empty(tag) => attach(&mut stack, &mut root, element(doc, &tag, at)?)?,
            Event::End(tag) => {
                // The reader has checked that the end tag matches the open element.
                let element = stack.pop().ok_or_else(|| {
                    let name = String::from_utf8_lossy(tag.name().as_ref()).into_owned();
                    Error::format(format!("XML at byte {at}: unexpected </{name}>"))
                })?;
                attach(&mut stack, &mut root, element)?;
            }
            Event::CData(_) => {
                return Err(Error::format(format!(
                    "XML at byte {at}: CDATA sections are not supported"
                )))
            }
            Event::Eof => break,
            Event::Text(_)
            | Event::GeneralRef(_)
            | Event::Comment(_)
            | Event::Decl(_)
            | Event::PI(_)
            | Event::DocType(_) => {}
        }
    }
    if let (Some(open), None) = (stack.last(), &rest) {
        return Err(Error::format(format!(
            "XML: <{}> is not closed; the file is truncated",
            open.name
        )));
    }
    while let Some(element) = stack.pop() {
        attach(&mut stack, &mut root, element)?;
    }
    let root = root.ok_or_else(|| Error::format("XML: no root element"))?;
    Ok(Document { root, rest })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn root(doc: &[u8]) -> Result<Element<'_>> {
        parse(doc, None).map(|d| d.root)
    }

    #[test]
    fn elements_attributes_text_and_entities() {
        let doc = br#"<?xml version="1.0"?>
            <!DOCTYPE x>
            <!-- a <comment> -->
            <A one="1" two = 'a &lt;&amp;&#x41;&#66;' >
              <B/>
              <C name="c">  1 2 3
                <D/>
                later text
              </C>
              <E>x &amp; y<!-- c --> z</E>
            </A>
        "#;
        let root = root(doc).unwrap();
        assert_eq!(root.name, "A");
        assert_eq!(root.attribute("one"), Some("1"));
        assert_eq!(root.attribute("two"), Some("a <&AB"));
        assert_eq!(root.attribute("three"), None);
        assert_eq!(root.children.len(), 3);
        let c = root.child("C").unwrap();
        assert_eq!(c.text, b"1 2 3");
        assert_eq!(c.children_named("D").count(), 1);
        assert_eq!(root.child("E").unwrap().text, b"x &amp; y");
    }

    #[test]
    fn unclosed_elements_close_only_where_parsing_stops() {
        let doc = b"<A><B x='1'/><C>";
        assert!(root(doc).unwrap_err().message().contains("truncated"));
        let doc = b"<A><B x='1'/><C><Data kind='raw'>\n_\x00<\xff";
        let parsed = parse(doc, Some("Data")).unwrap();
        assert_eq!(parsed.root.children.len(), 2);
        let (tag, rest) = parsed.rest.unwrap();
        assert_eq!(tag.attribute("kind"), Some("raw"));
        assert_eq!(rest, b"\n_\x00<\xff");
    }

    #[test]
    fn malformed_documents_are_errors() {
        for doc in [
            &b"<A></B>"[..],
            b"<A x=1/>",
            b"<A x='1/>",
            b"<A x='1' x='2'/>",
            b"<A/><B/>",
            b"text",
            b"<A/>text",
            b"<A x='&bogus;'/>",
            b"<A><![CDATA[1]]></A>",
            b"<!-- open",
            b"",
            b"<A",
            b"< />",
        ] {
            assert!(root(doc).is_err(), "{}", String::from_utf8_lossy(doc));
        }
        let deep = "<a>".repeat(MAX_DEPTH + 1);
        let e = parse(deep.as_bytes(), Some("b")).unwrap_err();
        assert!(e.message().contains("deeper"), "{e}");
        let e = root(b"<A>\n<B></C></A>").unwrap_err();
        assert!(e.message().contains("byte 7"), "{e}");
    }
}
