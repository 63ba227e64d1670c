#pragma once
// Checks of Collada and 3DS files before Assimp reads them, so that a broken file is refused
// at its place (Assimp 5.2 says only "Unable to read file, malformed XML" and "Chunk is too
// large"). Internal to convert/; both run in the reader's child process with the other checks
// of check_before_assimp (raw_model.h). Each throws ImportError naming the file.

#include <string>
#include <string_view>

namespace abrad::convert::detail {

/// Checks that a Collada file is well-formed XML (expat, a streaming parser: no document is
/// built, nesting costs no stack, no external entity is loaded): throws ImportError at the
/// line and column of the first error, with expat's reason.
void check_collada_xml(std::string_view bytes, const std::string& file);

/// Walks a 3DS file's chunks (a 2-byte id and a 4-byte length that counts the 6-byte header)
/// where Assimp's reader walks them: the main chunk, the editor, objects, meshes, materials and
/// the keyframer, and refuses the first chunk that runs past the end of the file (where
/// Assimp's "Chunk is too large" stops it), naming its byte offset, id and claimed length.
void check_3ds_chunks(std::string_view bytes, const std::string& file);

}  // namespace abrad::convert::detail
