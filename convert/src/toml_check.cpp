// toml++ in a child process before the scene file is parsed for real (issue 19).

#include <toml++/toml.h>

#include "abrad/convert/obj_import.h"
#include "child_process.h"

namespace abrad::convert::detail {

void check_toml_in_child(std::string_view bytes, const std::string& file) {
    try {
        (void)run_in_child([bytes] {
            try {
                (void)toml::parse(bytes);
            } catch (const toml::parse_error&) {
                // reported by the caller's parse, with its line
            }
            return std::string("parsed");
        });
    } catch (const ChildFailed& e) {
        throw ImportError(file, 0, std::string("the TOML reader failed (") + e.what() + ")");
    }
}

}  // namespace abrad::convert::detail
