// Writes the golden messages of the contract (golden_messages.h) to a folder, each as
// <stem>.binpb (deterministic wire form) and <stem>.json (proto3 JSON mapping).
// Not run by the tests: regenerate deliberately with
//   build/<preset>/bin/wj_make_golden tests/contract/golden
// and review the diff; a changed golden binary means a changed wire contract.
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <stdexcept>
#include <string>

#include "golden_messages.h"

namespace {

void writeFile(const std::filesystem::path& path, const std::string& contents) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(contents.data(), static_cast<std::streamsize>(contents.size()));
  out.close();
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: " << argv[0] << " <output folder, e.g. tests/contract/golden>\n";
    return EXIT_FAILURE;
  }
  try {
    const std::filesystem::path folder = argv[1];
    std::filesystem::create_directories(folder);
    for (const wj::contract::GoldenCase& golden : wj::contract::goldenCases()) {
      const auto message = golden.build();
      const std::string stem(golden.stem);
      writeFile(folder / (stem + ".binpb"), wj::contract::serializeDeterministic(*message));
      writeFile(folder / (stem + ".json"), wj::contract::printGoldenJson(*message));
      std::cout << "make_golden: " << (folder / stem).string() << ".{binpb,json} ("
                << message->GetTypeName() << ")\n";
    }
  } catch (const std::exception& error) {
    std::cerr << "make_golden: " << error.what() << '\n';
    return EXIT_FAILURE;
  }
  return EXIT_SUCCESS;
}
