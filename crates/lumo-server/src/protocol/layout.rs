//! The wire layout as data: every message declares its fields (name, byte offset, type,
//! count) in one `const` table, and its `write`/`read` go through that table, so the offsets
//! exist once. The same tables generate `web/protocol_layout.js` and the message tables of
//! docs/protocol.md ([`super::generate`]), which is how the viewer and the docs stay in step.

use super::error::{ErrorCode, ProtocolError};
use super::{HEADER_BYTES, VERSION};

/// How a field's bytes are read. All numbers are little-endian.
#[derive(Clone, Copy, Debug)]
pub enum FieldType {
    /// Unsigned byte.
    U8,
    /// Unsigned 16-bit integer.
    U16,
    /// Unsigned 32-bit integer.
    U32,
    /// Unsigned 64-bit integer.
    U64,
    /// IEEE single.
    F32,
    /// IEEE half.
    F16,
    /// `u16` holding `value · 65535` of a value in [0, 1].
    Unorm16,
    /// `u8`: 0 false, anything else true (1 when written).
    Bool,
    /// The wire code of an enumeration (its width is the enumeration's).
    Enum(&'static WireEnum),
    /// UTF-8 text.
    Utf8,
    /// Zero when written, ignored when read; kept in the table so the fields tile the message.
    Reserved,
    /// A fixed-size record of its own layout (a packed sample).
    Record(&'static Layout),
}

impl FieldType {
    /// Bytes of one element.
    pub const fn bytes(self) -> usize {
        match self {
            Self::U8 | Self::Bool | Self::Utf8 | Self::Reserved => 1,
            Self::U16 | Self::F16 | Self::Unorm16 => 2,
            Self::U32 | Self::F32 => 4,
            Self::U64 => 8,
            Self::Enum(e) => e.bytes,
            Self::Record(r) => r.bytes,
        }
    }

    /// The type's name in web/protocol_layout.js and docs/protocol.md.
    pub const fn name(self) -> &'static str {
        match self {
            Self::U8 => "u8",
            Self::U16 => "u16",
            Self::U32 => "u32",
            Self::U64 => "u64",
            Self::F32 => "f32",
            Self::F16 => "f16",
            Self::Unorm16 => "unorm16",
            Self::Bool => "bool",
            Self::Enum(_) => "enum",
            Self::Utf8 => "utf8",
            Self::Reserved => "reserved",
            Self::Record(_) => "record",
        }
    }
}

/// How many elements a field holds.
#[derive(Clone, Copy, Debug)]
pub enum Count {
    /// A fixed number.
    Fixed(usize),
    /// `factor` times the product of the named earlier fields (a length prefix, width·height);
    /// only the last field of a message may have one.
    Product(usize, &'static [&'static str]),
}

/// One field of a message or record.
#[derive(Clone, Copy, Debug)]
pub struct Field {
    /// Name, as the viewer's decoder returns it (camelCase).
    pub name: &'static str,
    /// Byte offset from the start of the message (header included) or record.
    pub offset: usize,
    /// Element type.
    pub ty: FieldType,
    /// Element count.
    pub count: Count,
    /// What it means, for docs/protocol.md.
    pub doc: &'static str,
}

impl Field {
    /// A single element at `offset`.
    pub const fn one(name: &'static str, offset: usize, ty: FieldType, doc: &'static str) -> Self {
        Self::fixed(name, offset, ty, 1, doc)
    }

    /// `count` elements at `offset`.
    pub const fn fixed(
        name: &'static str,
        offset: usize,
        ty: FieldType,
        count: usize,
        doc: &'static str,
    ) -> Self {
        Self {
            name,
            offset,
            ty,
            count: Count::Fixed(count),
            doc,
        }
    }

    /// A variable tail at `offset` of `factor · Π fields` elements.
    pub const fn tail(
        name: &'static str,
        offset: usize,
        ty: FieldType,
        factor: usize,
        fields: &'static [&'static str],
        doc: &'static str,
    ) -> Self {
        Self {
            name,
            offset,
            ty,
            count: Count::Product(factor, fields),
            doc,
        }
    }

    /// Bytes of a fixed-count field (0 for a variable tail).
    pub const fn bytes(&self) -> usize {
        match self.count {
            Count::Fixed(n) => n * self.ty.bytes(),
            Count::Product(..) => 0,
        }
    }

    /// First byte after a fixed-count field.
    pub const fn end(&self) -> usize {
        self.offset + self.bytes()
    }
}

/// Which side sends a message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// Server → viewer only.
    ToViewer,
    /// Both ways.
    Both,
    /// Hub → remote render worker (docs/protocol.md, "Remote render workers").
    ToWorker,
    /// Remote render worker → hub.
    FromWorker,
}

/// The layout of one message (or of a record inside one).
#[derive(Clone, Copy, Debug)]
pub struct Layout {
    /// Upper-case name (the key in web/protocol_layout.js).
    pub name: &'static str,
    /// Type byte; 0 for a record, which has no header.
    pub kind: u8,
    /// Who sends it.
    pub direction: Direction,
    /// Fields in offset order (the message's header not included).
    pub fields: &'static [Field],
    /// Bytes before the variable tail, if any (header included).
    pub bytes: usize,
}

impl Layout {
    /// A message: its fixed size is where its last fixed field ends.
    pub const fn message(
        name: &'static str,
        kind: u8,
        direction: Direction,
        fields: &'static [Field],
    ) -> Self {
        Self {
            name,
            kind,
            direction,
            fields,
            bytes: fixed_end(fields, HEADER_BYTES),
        }
    }

    /// A record: fields from offset 0, no header.
    pub const fn record(name: &'static str, fields: &'static [Field]) -> Self {
        Self {
            name,
            kind: 0,
            direction: Direction::ToViewer,
            fields,
            bytes: fixed_end(fields, 0),
        }
    }

    /// The variable tail, if the message has one.
    pub fn tail(&self) -> Option<&'static Field> {
        self.fields
            .last()
            .filter(|f| matches!(f.count, Count::Product(..)))
    }
}

const fn fixed_end(fields: &[Field], start: usize) -> usize {
    let mut end = start;
    let mut i = 0;
    while i < fields.len() {
        if fields[i].end() > end {
            end = fields[i].end();
        }
        i += 1;
    }
    end
}

/// The common header of every message, as a record.
pub const HEADER: Layout = Layout::record(
    "HEADER",
    &[
        Field::one("kind", 0, FieldType::U8, "message type"),
        Field::one("version", 1, FieldType::U8, "protocol version (1)"),
        Field::fixed("reserved", 2, FieldType::Reserved, 2, "reserved, 0"),
    ],
);

/// One value of an enumeration on the wire.
#[derive(Clone, Copy, Debug)]
pub struct Variant {
    /// Wire code.
    pub code: u16,
    /// Name in the viewer and on the command line.
    pub name: &'static str,
    /// Label for people (the viewer's menus).
    pub label: &'static str,
}

/// An enumeration as data: its wire codes, names and labels.
#[derive(Clone, Copy, Debug)]
pub struct WireEnum {
    /// Name (the key in web/protocol_layout.js's `ENUMS`).
    pub name: &'static str,
    /// Bytes of its code on the wire.
    pub bytes: usize,
    /// Its values in code order.
    pub variants: &'static [Variant],
}

/// Defines a wire enumeration and its table ([`WireEnum`]) in one place: the Rust enum, its
/// codes, the names the viewer uses and the labels of its menus.
macro_rules! wire_enum {
    (
        $(#[$meta:meta])*
        pub enum $name:ident: $repr:ident, $wire:literal {
            $( $(#[$vmeta:meta])* $variant:ident = $code:literal, $id:literal, $label:literal; )+
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        #[repr($repr)]
        pub enum $name {
            $( $(#[$vmeta])* $variant = $code, )+
        }

        impl $name {
            /// Every value, in wire-code order.
            pub const ALL: &'static [Self] = &[$(Self::$variant),+];
            /// The enumeration as data (generated into web/protocol_layout.js).
            pub const WIRE: $crate::protocol::layout::WireEnum =
                $crate::protocol::layout::WireEnum {
                    name: $wire,
                    bytes: ::std::mem::size_of::<$repr>(),
                    variants: &[$($crate::protocol::layout::Variant {
                        code: $code,
                        name: $id,
                        label: $label,
                    }),+],
                };

            /// From the wire code.
            pub fn from_code(code: $repr) -> Option<Self> {
                match code {
                    $($code => Some(Self::$variant),)+
                    _ => None,
                }
            }

            /// The wire code.
            pub const fn code(self) -> $repr {
                self as $repr
            }

            /// Name used by the viewer (and the command line).
            pub const fn name(self) -> &'static str {
                match self {
                    $(Self::$variant => $id,)+
                }
            }

            /// Label for people (the viewer's menus).
            pub const fn label(self) -> &'static str {
                match self {
                    $(Self::$variant => $label,)+
                }
            }
        }
    };
}
pub(super) use wire_enum;

/// Little-endian numbers of fixed size, as fields hold them.
pub(super) trait Scalar: Copy {
    /// Bytes on the wire.
    const BYTES: usize;
    /// Appends the little-endian bytes.
    fn put(self, out: &mut [u8]);
    /// Reads from exactly [`Self::BYTES`] bytes.
    fn get(b: &[u8]) -> Self;
}

macro_rules! scalar {
    ($($t:ty),+) => {$(
        impl Scalar for $t {
            const BYTES: usize = std::mem::size_of::<$t>();
            fn put(self, out: &mut [u8]) {
                out.copy_from_slice(&self.to_le_bytes());
            }
            fn get(b: &[u8]) -> Self {
                let mut a = [0; std::mem::size_of::<$t>()];
                a.copy_from_slice(b);
                <$t>::from_le_bytes(a)
            }
        }
    )+};
}
scalar!(u8, u16, u32, u64, f32);

/// Writes a message: the fixed part is allocated zeroed (so reserved bytes are 0) and each
/// value goes to its field's offset; a variable tail is appended.
pub(super) struct Writer {
    buf: Vec<u8>,
}

impl Writer {
    /// A message of `layout` with room for `tail` more bytes; the header is written.
    pub(super) fn new(layout: &Layout, tail: usize) -> Self {
        let mut buf = Vec::with_capacity(layout.bytes + tail);
        buf.resize(layout.bytes, 0);
        buf[0] = layout.kind;
        buf[1] = VERSION;
        Self { buf }
    }

    /// Writes element `i` of `field`.
    pub(super) fn put_at<T: Scalar>(&mut self, field: &Field, i: usize, v: T) {
        debug_assert_eq!(field.ty.bytes(), T::BYTES, "{}", field.name);
        let at = field.offset + i * T::BYTES;
        v.put(&mut self.buf[at..at + T::BYTES]);
    }

    /// Writes a single-element field.
    pub(super) fn put<T: Scalar>(&mut self, field: &Field, v: T) {
        self.put_at(field, 0, v);
    }

    /// Writes `bytes` into a fixed-size byte field, cut to its size (the rest stays 0).
    pub(super) fn put_bytes(&mut self, field: &Field, bytes: &[u8]) {
        let n = bytes.len().min(field.bytes());
        self.buf[field.offset..field.offset + n].copy_from_slice(&bytes[..n]);
    }

    /// Appends tail bytes (the tail field starts where the fixed part ends).
    pub(super) fn extend(&mut self, bytes: &[u8]) {
        self.buf.extend_from_slice(bytes);
    }

    /// The encoded message.
    pub(super) fn finish(self) -> Vec<u8> {
        self.buf
    }
}

/// Reads a message's fields at their offsets. Every failure is a [`ProtocolError`], never a
/// panic: the length is checked against the layout before any field is read.
pub(super) struct Reader<'a> {
    msg: &'a [u8],
    layout: Layout,
}

impl<'a> Reader<'a> {
    /// A reader over a whole message (header included) of `layout`; refuses one shorter than
    /// its fixed part (before any value is looked at, so a short message is always "malformed").
    pub(super) fn new(msg: &'a [u8], layout: &Layout) -> Result<Self, ProtocolError> {
        if msg.len() < layout.bytes {
            return Err(ProtocolError::new(
                ErrorCode::Malformed,
                "message too short",
            ));
        }
        Ok(Self {
            msg,
            layout: *layout,
        })
    }

    /// Element `i` of `field`.
    pub(super) fn get_at<T: Scalar>(&self, field: &Field, i: usize) -> Result<T, ProtocolError> {
        debug_assert_eq!(field.ty.bytes(), T::BYTES, "{}", field.name);
        let at = field.offset + i * T::BYTES;
        self.msg
            .get(at..at + T::BYTES)
            .map(T::get)
            .ok_or_else(|| ProtocolError::new(ErrorCode::Malformed, "message too short"))
    }

    /// A single-element field.
    pub(super) fn get<T: Scalar>(&self, field: &Field) -> Result<T, ProtocolError> {
        self.get_at(field, 0)
    }

    /// The bytes of a fixed-size field.
    pub(super) fn bytes(&self, field: &Field) -> Result<&'a [u8], ProtocolError> {
        self.msg
            .get(field.offset..field.end())
            .ok_or_else(|| ProtocolError::new(ErrorCode::Malformed, "message too short"))
    }

    /// The variable tail, which must be exactly `bytes` long (`what` names it in the error).
    pub(super) fn tail(&self, bytes: usize, what: &str) -> Result<&'a [u8], ProtocolError> {
        let rest = &self.msg[self.layout.bytes..];
        if rest.len() != bytes {
            return Err(ProtocolError::new(ErrorCode::Malformed, what));
        }
        Ok(rest)
    }

    /// Refuses bytes after the fixed part of a message without a tail.
    pub(super) fn end(&self) -> Result<(), ProtocolError> {
        let extra = self.msg.len() - self.layout.bytes;
        if extra == 0 || self.layout.tail().is_some() {
            Ok(())
        } else {
            Err(ProtocolError::new(
                ErrorCode::Malformed,
                format!("{extra} unexpected trailing bytes"),
            ))
        }
    }
}
