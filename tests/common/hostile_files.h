#pragma once
// Hostile model files shared by the reader tests and the command-line tests (issue 19).

#include <algorithm>
#include <cstddef>
#include <string>
#include <string_view>

namespace abrad::testing {

/// A DXF whose nested MINSERTs ask for 10^10 faces in a few hundred bytes: block B2 holds
/// 1,000 × 100 copies of B1, which holds 1,000 × 100 copies of B0's one 3DFACE; the
/// entities insert B2 once, with entity handle `handle`.
inline std::string dxf_insert_bomb(const std::string& handle) {
    std::string s = "0\nSECTION\n2\nBLOCKS\n";
    s += "0\nBLOCK\n8\n0\n2\nB0\n10\n0\n20\n0\n30\n0\n";
    s += "0\n3DFACE\n8\n0\n10\n0\n20\n0\n30\n0\n11\n1\n21\n0\n31\n0\n12\n1\n22\n1\n32\n0\n";
    s += "0\nENDBLK\n";
    s += "0\nBLOCK\n8\n0\n2\nB1\n10\n0\n20\n0\n30\n0\n";
    s += "0\nINSERT\n8\n0\n2\nB0\n70\n1000\n71\n100\n44\n1\n45\n1\n0\nENDBLK\n";
    s += "0\nBLOCK\n8\n0\n2\nB2\n10\n0\n20\n0\n30\n0\n";
    s += "0\nINSERT\n8\n0\n2\nB1\n70\n1000\n71\n100\n44\n1\n45\n1\n0\nENDBLK\n";
    s += "0\nENDSEC\n0\nSECTION\n2\nENTITIES\n";
    s += "0\nINSERT\n5\n" + handle + "\n8\nMisc\n2\nB2\n";
    s += "0\nENDSEC\n0\nEOF\n";
    return s;
}

/// The 1-based line of `text` on which `needle` starts (needle must occur).
inline std::size_t line_of(const std::string& text, std::string_view needle) {
    const auto at = static_cast<std::ptrdiff_t>(text.find(needle));
    return static_cast<std::size_t>(std::count(text.begin(), text.begin() + at, '\n')) + 1;
}

}  // namespace abrad::testing
