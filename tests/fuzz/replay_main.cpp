// Corpus replay without libFuzzer: feeds every file under the given directories (sorted, each
// once) to the harness's LLVMFuzzerTestOneInput. Built with any compiler, so the committed corpora
// run as ordinary tests in every build, the ASan/UBSan one included; a harness invariant that
// fails aborts the process and the test. An empty or missing corpus is an error, not a pass.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

int main(int argc, char** argv) {
  namespace fs = std::filesystem;
  std::vector<fs::path> files;
  for (int i = 1; i < argc; ++i) {
    std::error_code ec;
    for (fs::recursive_directory_iterator it(argv[i], ec), end; !ec && it != end; it.increment(ec))
      if (it->is_regular_file()) files.push_back(it->path());
    if (ec) {
      std::fprintf(stderr, "cannot read corpus %s: %s\n", argv[i], ec.message().c_str());
      return 2;
    }
  }
  if (files.empty()) {
    std::fprintf(stderr, "no corpus files (usage: %s CORPUS_DIR...)\n", argv[0]);
    return 2;
  }
  std::sort(files.begin(), files.end());
  for (const auto& f : files) {
    std::ifstream in(f, std::ios::binary);
    const std::vector<char> bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    std::fprintf(stderr, "%s (%zu bytes)\n", f.c_str(), bytes.size());
    // A copy of exactly `size` bytes: ASan sees a read past the input as libFuzzer would.
    std::vector<std::uint8_t> input(bytes.begin(), bytes.end());
    const std::uint8_t* data = input.empty() ? nullptr : input.data();
    (void)LLVMFuzzerTestOneInput(data, input.size());
  }
  std::printf("%zu corpus inputs replayed\n", files.size());
  return 0;
}
