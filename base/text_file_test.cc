#include "base/text_file.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <fstream>

namespace mm {
namespace {

std::filesystem::path TempPath(const std::string& name) {
  return std::filesystem::temp_directory_path() /
         ("mm_text_file_" + name + "_" + std::to_string(::getpid()));
}

TEST(ReadTextFile, ReadsARegularFileWhole) {
  const auto path = TempPath("regular");
  std::ofstream(path, std::ios::binary) << std::string(200000, 'x') << "end";
  std::string error;
  const std::optional<std::string> text = ReadTextFile(path, 1 << 20, &error);
  ASSERT_TRUE(text.has_value()) << error;
  EXPECT_EQ(text->size(), 200003u);
  EXPECT_EQ(text->substr(text->size() - 3), "end");
  std::filesystem::remove(path);
}

// A FIFO without a writer and a device that never ends are refused at once, not read.
TEST(ReadTextFile, FifoAndDeviceAreNotRegularFiles) {
  const auto fifo = TempPath("fifo");
  std::filesystem::remove(fifo);
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::string error;
  EXPECT_FALSE(ReadTextFile(fifo, 1 << 20, &error).has_value());
  EXPECT_EQ(error, fifo.string() + ": not a regular file");
  std::filesystem::remove(fifo);
  EXPECT_FALSE(ReadTextFile("/dev/zero", 1 << 20, &error).has_value());
  EXPECT_EQ(error, "/dev/zero: not a regular file");
}

TEST(ReadTextFile, TooLargeOrMissingNamesThePath) {
  const auto path = TempPath("large");
  std::ofstream(path, std::ios::binary) << std::string(5000, 'x');
  std::string error;
  EXPECT_FALSE(ReadTextFile(path, 4096, &error).has_value());
  EXPECT_EQ(error, path.string() + ": larger than 4096 bytes");
  EXPECT_TRUE(ReadTextFile(path, 5000, &error).has_value());
  std::filesystem::remove(path);
  EXPECT_FALSE(ReadTextFile(path, 4096, &error).has_value());
  EXPECT_NE(error.find(path.string() + ": cannot open for reading"), std::string::npos) << error;
}

}  // namespace
}  // namespace mm
