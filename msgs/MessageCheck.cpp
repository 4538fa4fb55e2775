#include "msgs/MessageCheck.hpp"

#include <cstdio>
#include <cstring>

namespace areomap::msgs {
namespace {

// Bounds of the schema tables (sized for msgs/*.lcm with room to grow; a schema beyond them fails to parse
// and every check then returns kUnsupported, which the schema test catches).
constexpr int32_t kMaxTypes = 16;       // message and nested types (10 today)
constexpr int32_t kMaxFields = 32;      // fields per type, const members not stored (26 today)
constexpr int32_t kMaxNameChars = 40;   // identifier length + NUL
constexpr int32_t kMaxDims = 2;         // array dimensions per field (1 today)
constexpr int32_t kMaxNesting = 8;      // depth of nested types (bounds the walk's recursion)
constexpr int32_t kMaxTokens = 100000;  // tokens per schema text (bounds the parser's loops)

const char* const kSchemaTexts[] = {
#include "areomap_msgs_schema.inc"
};
constexpr int32_t kNumSchemaTexts = static_cast<int32_t>(sizeof(kSchemaTexts) / sizeof(kSchemaTexts[0]));

enum class Kind : uint8_t {
  kInt8,
  kInt16,
  kInt32,
  kInt64,
  kFloat,
  kDouble,
  kString,
  kBoolean,
  kByte,
  kStruct
};

struct Dim {
  bool is_constant;
  int32_t constant;
  int32_t field;  // index of an earlier integer scalar field of the same type
};

struct Field {
  char name[kMaxNameChars];
  char type_name[kMaxNameChars];
  Kind kind;
  int32_t struct_index;  // for kStruct
  int32_t num_dims;
  Dim dims[kMaxDims];
};

struct Type {
  char name[kMaxNameChars];
  int32_t num_fields;
  Field fields[kMaxFields];
};

struct Schema {
  int32_t num_types = 0;
  Type types[kMaxTypes];
  char error[160] = {0};
};

// ---- tokenizer -------------------------------------------------------------------------------------------

struct Lexer {
  const char* p;
  char token[kMaxNameChars];
  bool overflow = false;

  // Next token into `token` (identifier, number or one punctuation character); false at the end.
  bool next() {
    for (int32_t guard = 0; guard < kMaxTokens; ++guard) {
      while (*p == ' ' || *p == '\t' || *p == '\n' || *p == '\r') ++p;
      if (p[0] == '/' && p[1] == '/') {
        while (*p != '\0' && *p != '\n') ++p;
        continue;
      }
      if (p[0] == '/' && p[1] == '*') {
        p += 2;
        while (*p != '\0' && !(p[0] == '*' && p[1] == '/')) ++p;
        if (*p != '\0') p += 2;
        continue;
      }
      break;
    }
    if (*p == '\0') return false;
    int32_t n = 0;
    const auto word = [](char c) {
      return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
             c == '.' || c == '-' || c == '+';
    };
    if (word(*p)) {
      while (word(*p)) {
        if (n + 1 >= kMaxNameChars) {
          overflow = true;
          return false;
        }
        token[n++] = *p++;
      }
    } else {
      token[n++] = *p++;
    }
    token[n] = '\0';
    return true;
  }
  bool is(const char* s) const { return std::strcmp(token, s) == 0; }
};

bool setError(Schema& schema, const char* what, const char* where) {
  std::snprintf(schema.error, sizeof(schema.error), "%s%s", what, where);
  return false;
}

bool isInteger(Kind kind) {
  return kind == Kind::kInt8 || kind == Kind::kInt16 || kind == Kind::kInt32 || kind == Kind::kInt64;
}

bool primitiveKind(const char* name, Kind& kind) {
  struct Entry {
    const char* name;
    Kind kind;
  };
  static const Entry kTable[] = {
      {"int8_t", Kind::kInt8},   {"int16_t", Kind::kInt16},   {"int32_t", Kind::kInt32},
      {"int64_t", Kind::kInt64}, {"float", Kind::kFloat},     {"double", Kind::kDouble},
      {"string", Kind::kString}, {"boolean", Kind::kBoolean}, {"byte", Kind::kByte}};
  for (const Entry& e : kTable) {
    if (std::strcmp(e.name, name) == 0) {
      kind = e.kind;
      return true;
    }
  }
  return false;
}

// Parses one .lcm text: `package x;` and `struct name { fields and const members }`.
bool parseText(Schema& schema, const char* text) {
  Lexer lex{text, {0}};
  for (int32_t guard = 0; guard < kMaxTokens && lex.next(); ++guard) {
    if (lex.is("package")) {
      while (lex.next() && !lex.is(";")) {
      }
      continue;
    }
    if (!lex.is("struct")) return setError(schema, "expected 'struct' at ", lex.token);
    if (schema.num_types >= kMaxTypes) return setError(schema, "too many types at ", lex.token);
    Type& type = schema.types[schema.num_types++];
    type.num_fields = 0;
    if (!lex.next()) return setError(schema, "missing struct name", "");
    std::strcpy(type.name, lex.token);
    if (!lex.next() || !lex.is("{")) return setError(schema, "expected '{' after ", type.name);
    for (int32_t member = 0; member < kMaxTokens; ++member) {
      if (!lex.next()) return setError(schema, "unterminated struct ", type.name);
      if (lex.is("}")) break;
      if (lex.is("const")) {
        while (lex.next() && !lex.is(";")) {
        }
        continue;
      }
      if (type.num_fields >= kMaxFields) return setError(schema, "too many fields in ", type.name);
      Field& field = type.fields[type.num_fields];
      field.num_dims = 0;
      field.struct_index = -1;
      std::strcpy(field.type_name, lex.token);
      if (!primitiveKind(field.type_name, field.kind)) field.kind = Kind::kStruct;
      if (!lex.next()) return setError(schema, "missing field name in ", type.name);
      std::strcpy(field.name, lex.token);
      for (int32_t d = 0; d <= kMaxDims; ++d) {
        if (!lex.next()) return setError(schema, "unterminated field ", field.name);
        if (lex.is(";")) break;
        if (!lex.is("[") || field.num_dims >= kMaxDims)
          return setError(schema, "bad dimension of ", field.name);
        if (!lex.next()) return setError(schema, "bad dimension of ", field.name);
        Dim& dim = field.dims[field.num_dims++];
        dim.is_constant = lex.token[0] >= '0' && lex.token[0] <= '9';
        dim.constant = 0;
        dim.field = -1;
        if (dim.is_constant) {
          int64_t value = 0;
          for (const char* c = lex.token; *c != '\0'; ++c) {
            if (*c < '0' || *c > '9') return setError(schema, "bad constant dimension of ", field.name);
            value = value * 10 + (*c - '0');
            if (value > INT32_MAX) return setError(schema, "dimension too large in ", field.name);
          }
          dim.constant = static_cast<int32_t>(value);
        } else {
          for (int32_t g = 0; g < type.num_fields; ++g) {  // a dimension names an earlier integer scalar
            const Field& size_field = type.fields[g];
            if (std::strcmp(size_field.name, lex.token) == 0 && size_field.num_dims == 0 &&
                isInteger(size_field.kind)) {
              dim.field = g;
            }
          }
          if (dim.field < 0) return setError(schema, "unknown dimension ", lex.token);
        }
        if (!lex.next() || !lex.is("]")) return setError(schema, "expected ']' in ", field.name);
      }
      ++type.num_fields;
    }
  }
  if (lex.overflow) return setError(schema, "identifier too long in schema", "");
  return true;
}

const char* shortName(const char* name) {
  const char* dot = std::strrchr(name, '.');
  return dot != nullptr ? dot + 1 : name;
}

int32_t findType(const Schema& schema, const char* name) {
  for (int32_t i = 0; i < schema.num_types; ++i) {
    if (std::strcmp(schema.types[i].name, shortName(name)) == 0) return i;
  }
  return -1;
}

// Resolves nested type names.
bool resolve(Schema& schema) {
  for (int32_t t = 0; t < schema.num_types; ++t) {
    Type& type = schema.types[t];
    for (int32_t f = 0; f < type.num_fields; ++f) {
      Field& field = type.fields[f];
      if (field.kind == Kind::kStruct) {
        field.struct_index = findType(schema, field.type_name);
        if (field.struct_index < 0) return setError(schema, "unknown type ", field.type_name);
      }
    }
  }
  return true;
}

Schema g_schema;

const Schema& schema() {
  static const bool parsed = [] {
    for (int32_t i = 0; i < kNumSchemaTexts; ++i) {
      if (!parseText(g_schema, kSchemaTexts[i])) return false;
    }
    return resolve(g_schema);
  }();
  if (!parsed && g_schema.error[0] == '\0') setError(g_schema, "schema did not parse", "");
  return g_schema;
}

// ---- walk ------------------------------------------------------------------------------------------------

struct Cursor {
  const uint8_t* data;
  int64_t size;
  int64_t pos;
  int64_t left() const { return size - pos; }
  int64_t readSigned(int32_t bytes) {  // big-endian two's complement, as LCM encodes
    uint64_t v = 0;
    for (int32_t i = 0; i < bytes; ++i) v = (v << 8) | data[pos + i];
    pos += bytes;
    const int32_t shift = 64 - 8 * bytes;
    return static_cast<int64_t>(v << shift) >> shift;
  }
};

int32_t primitiveBytes(Kind kind) {
  switch (kind) {
    case Kind::kInt8:
    case Kind::kBoolean:
    case Kind::kByte:
      return 1;
    case Kind::kInt16:
      return 2;
    case Kind::kInt32:
    case Kind::kFloat:
      return 4;
    case Kind::kInt64:
    case Kind::kDouble:
      return 8;
    case Kind::kString:
    case Kind::kStruct:
      break;
  }
  return 0;
}

// Recursion is bounded by kMaxNesting (nested types cannot be cyclic in LCM, and the depth is checked).
// `longest_string` grows to the longest string walked (characters without the NUL).
Status walkType(const Schema& schema, int32_t type_index, Cursor& cursor, int32_t depth,
                int64_t& longest_string) {
  if (depth >= kMaxNesting) return Status::kCorruptData;
  const Type& type = schema.types[type_index];
  int64_t values[kMaxFields] = {0};
  for (int32_t f = 0; f < type.num_fields; ++f) {
    const Field& field = type.fields[f];
    int64_t count = 1;
    for (int32_t d = 0; d < field.num_dims; ++d) {
      const int64_t n = field.dims[d].is_constant ? field.dims[d].constant : values[field.dims[d].field];
      if (n < 0) return Status::kCorruptData;
      if (n > cursor.left() && n > 0) return Status::kTruncated;  // every element takes at least one byte
      count *= n;
      if (count > cursor.left() && count > 0) return Status::kTruncated;
    }
    if (field.kind == Kind::kString) {
      for (int64_t i = 0; i < count; ++i) {
        if (cursor.left() < 4) return Status::kTruncated;
        const int64_t length = cursor.readSigned(4);
        if (length < 1) return Status::kCorruptData;  // LCM writes the NUL terminator
        if (length > cursor.left()) return Status::kTruncated;
        // LCM writes strlen + 1 bytes: exactly one NUL, at the end.
        if (cursor.data[cursor.pos + length - 1] != 0) return Status::kCorruptData;
        if (std::memchr(cursor.data + cursor.pos, 0, static_cast<std::size_t>(length - 1)) != nullptr) {
          return Status::kCorruptData;
        }
        if (length - 1 > longest_string) longest_string = length - 1;
        cursor.pos += length;
      }
    } else if (field.kind == Kind::kStruct) {
      for (int64_t i = 0; i < count; ++i) {
        const Status status = walkType(schema, field.struct_index, cursor, depth + 1, longest_string);
        if (!ok(status)) return status;
      }
    } else {
      const int32_t bytes = primitiveBytes(field.kind);
      if (count * bytes > cursor.left()) return Status::kTruncated;
      if (field.num_dims == 0 && isInteger(field.kind)) {
        values[f] = cursor.readSigned(bytes);
      } else {
        cursor.pos += count * bytes;
      }
    }
  }
  return Status::kOk;
}

}  // namespace

Status checkEncoding(const char* type_name, uint64_t hash, const uint8_t* data, std::size_t size) {
  int64_t longest_string = 0;
  return checkEncoding(type_name, hash, data, size, longest_string);
}

Status checkEncoding(const char* type_name, uint64_t hash, const uint8_t* data, std::size_t size,
                     int64_t& longest_string_chars) {
  longest_string_chars = 0;
  const Schema& s = schema();
  if (s.error[0] != '\0') return Status::kUnsupported;
  if (type_name == nullptr || data == nullptr) return Status::kInvalidArgument;
  const int32_t type_index = findType(s, type_name);
  if (type_index < 0) return Status::kInvalidArgument;
  if (size > static_cast<std::size_t>(INT32_MAX)) return Status::kCapacityExceeded;
  Cursor cursor{data, static_cast<int64_t>(size), 0};
  if (cursor.left() < 8) return Status::kTruncated;
  if (static_cast<uint64_t>(cursor.readSigned(8)) != hash) return Status::kCorruptData;
  const Status status = walkType(s, type_index, cursor, 0, longest_string_chars);
  if (!ok(status)) return status;
  return cursor.pos == cursor.size ? Status::kOk : Status::kCorruptData;
}

int32_t schemaTypeCount() {
  return schema().num_types;
}

const char* schemaError() {
  return schema().error;
}

}  // namespace areomap::msgs
