// util/keyed_store.h: a folder of numbered items that belongs to one key; opened for
// another key it is moved aside first (one generation kept: a rerun with a mistyped flag
// had deleted a stopped run's items before making any of its own).

#include "util/keyed_store.h"

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "testing/temp_dir.h"
#include "util/atomic_file.h"
#include "util/make_directory.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;

TEST(KeyedStoreTest, ItemsStayForTheSameKeyAndGoForAnother) {
  testing::TempDir dir;
  const std::string folder = dir.File("a/b/store");
  KeyedStore store;
  EXPECT_FALSE(store.is_open());
  std::string error;
  ASSERT_TRUE(store.Open(folder, "key one\n", &error)) << error;
  EXPECT_TRUE(store.is_open());
  EXPECT_EQ(ReadWholeFile(folder + "/key.txt"), "key one\n");
  EXPECT_EQ(store.ItemPath(7, "bin"), folder + "/0007.bin");
  EXPECT_EQ(store.ItemPath(12345, "txt"), folder + "/12345.txt");
  std::ofstream(store.ItemPath(7, "txt")) << "done";
  // The same key: the item stays.
  ASSERT_TRUE(store.Open(folder, "key one\n", &error)) << error;
  EXPECT_EQ(ReadWholeFile(store.ItemPath(7, "txt")), "done");
  // Another key: the items move aside (kept), and the new key is written.
  ASSERT_TRUE(store.Open(folder, "key two\n", &error)) << error;
  EXPECT_FALSE(fs::exists(store.ItemPath(7, "txt")));
  EXPECT_EQ(ReadWholeFile(folder + "/key.txt"), "key two\n");
  const std::string previous = KeyedStore::PreviousPath(folder);
  EXPECT_EQ(previous, folder + ".previous");
  EXPECT_EQ(ReadWholeFile(previous + "/0007.txt"), "done");
  EXPECT_EQ(ReadWholeFile(previous + "/key.txt"), "key one\n");
  // A folder without a key (someone else's files) moves aside too, replacing the
  // earlier generation.
  fs::remove(folder + "/key.txt");
  std::ofstream(folder + "/stray.txt") << "x";
  ASSERT_TRUE(store.Open(folder, "key two\n", &error)) << error;
  EXPECT_FALSE(fs::exists(folder + "/stray.txt"));
  EXPECT_TRUE(fs::exists(previous + "/stray.txt"));
  EXPECT_FALSE(fs::exists(previous + "/0007.txt"));
  ASSERT_TRUE(RemoveDirectory(previous, &error)) << error;
  // Removed as a whole; a missing folder is fine.
  ASSERT_TRUE(RemoveDirectory(folder, &error)) << error;
  EXPECT_FALSE(fs::exists(folder));
  EXPECT_TRUE(RemoveDirectory(folder, &error)) << error;
  EXPECT_EQ(ReadWholeFile(folder + "/key.txt"), "");
}

TEST(KeyedStoreTest, AFolderThatCannotBeMadeFailsNamingIt) {
  testing::TempDir dir;
  const std::string file = dir.Write("file", "not a folder");
  KeyedStore store;
  std::string error;
  EXPECT_FALSE(store.Open(file + "/store", "key\n", &error));
  EXPECT_NE(error.find(file + "/store"), std::string::npos) << error;
  EXPECT_FALSE(store.is_open());
}

}  // namespace
}  // namespace aqs
