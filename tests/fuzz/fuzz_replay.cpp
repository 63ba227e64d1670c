// The corpus replay (CTest): `fuzz_replay CORPUS NAME` runs every file of CORPUS/NAME through
// the fuzz target NAME; `fuzz_replay CORPUS` checks that every corpus folder has a target and
// every target a folder. A crash or sanitizer report fails the test; so does an empty folder.

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <string>
#include <vector>

#include "fuzz_target.h"

namespace fs = std::filesystem;

int main(int argc, char** argv) {
    if (argc != 2 && argc != 3) {
        std::cerr << "usage: fuzz_replay CORPUS [TARGET]\n";
        return 2;
    }
    const fs::path corpus = argv[1];
    const auto& targets = abrad::fuzz::targets();
    if (argc == 2) {
        int missing = 0;
        for (const auto& [name, target] : targets) {
            if (!fs::is_directory(corpus / name)) {
                std::cerr << "target " << name << " has no corpus folder " << (corpus / name)
                          << "\n";
                ++missing;
            }
        }
        for (const fs::directory_entry& e : fs::directory_iterator(corpus)) {
            if (e.is_directory() && targets.count(e.path().filename().string()) == 0) {
                std::cerr << "corpus folder " << e.path() << " has no target\n";
                ++missing;
            }
        }
        return missing == 0 ? 0 : 1;
    }
    const auto it = targets.find(argv[2]);
    if (it == targets.end()) {
        std::cerr << "no fuzz target " << argv[2] << "\n";
        return 2;
    }
    std::vector<fs::path> files;
    for (const fs::directory_entry& e : fs::directory_iterator(corpus / argv[2]))
        if (e.is_regular_file()) files.push_back(e.path());
    std::sort(files.begin(), files.end());
    if (files.empty()) {
        std::cerr << "corpus " << (corpus / argv[2]) << " is empty\n";
        return 1;
    }
    for (const fs::path& f : files) {
        std::ifstream in(f, std::ios::binary);
        const std::string bytes{std::istreambuf_iterator<char>(in),
                                std::istreambuf_iterator<char>()};
        std::cout << f.filename().string() << " (" << bytes.size() << " bytes)" << std::endl;
        it->second(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
    }
    std::cout << files.size() << " inputs through " << argv[2] << ", no crash\n";
    return 0;
}
