#pragma once
// Names from CAD files as valid UTF-8 (what glTF's JSON requires). CAD tools write names in
// UTF-8, Latin-1 or Windows-1252 without saying which.

#include <string>
#include <string_view>

namespace abrad::exporter {

/// A name made valid UTF-8, and whether it had to be transcoded.
struct Utf8Text {
    std::string text;
    bool transcoded = false;
};

/// `bytes` unchanged when it is valid UTF-8 (no overlong forms, surrogates or code points past
/// U+10FFFF); otherwise every byte read as Windows-1252 (Latin-1 with typographic characters
/// in 0x80-0x9F), the five bytes that code page leaves undefined becoming U+FFFD.
Utf8Text to_utf8(std::string_view bytes);

}  // namespace abrad::exporter
