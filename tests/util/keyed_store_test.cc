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

// Run A stopped with items kept, run B (a mistyped flag) stopped, run A again: A's items
// come back from the folder moved aside, and B's are kept there in their turn (A's were
// deleted when B's replaced them). A store whose folder is gone takes them back too.
TEST(KeyedStoreTest, TheKeysFolderMovedAsideIsTakenBack) {
  testing::TempDir dir;
  const std::string folder = dir.File("store");
  const std::string previous = KeyedStore::PreviousPath(folder);
  KeyedStore store;
  std::string error;
  ASSERT_TRUE(store.Open(folder, "A\n", &error)) << error;
  std::ofstream(store.ItemPath(0, "txt")) << "A's fit";
  ASSERT_TRUE(store.Open(folder, "B\n", &error)) << error;
  std::ofstream(store.ItemPath(0, "txt")) << "B's fit";
  ASSERT_TRUE(store.Open(folder, "A\n", &error)) << error;
  EXPECT_EQ(ReadWholeFile(folder + "/0000.txt"), "A's fit");
  EXPECT_EQ(ReadWholeFile(folder + "/key.txt"), "A\n");
  EXPECT_EQ(ReadWholeFile(previous + "/0000.txt"), "B's fit");
  EXPECT_EQ(ReadWholeFile(previous + "/key.txt"), "B\n");
  EXPECT_FALSE(fs::exists(folder + ".exchange"));
  // B stopped before its first item: A's comes back all the same.
  ASSERT_TRUE(store.Open(folder, "B\n", &error)) << error;  // A's aside, B's back
  fs::remove(folder + "/0000.txt");
  ASSERT_TRUE(store.Open(folder, "A\n", &error)) << error;
  EXPECT_EQ(ReadWholeFile(folder + "/0000.txt"), "A's fit");
  EXPECT_EQ(ReadWholeFile(previous + "/key.txt"), "B\n");
  // The folder itself gone: the one moved aside with this key comes back.
  ASSERT_TRUE(store.Open(folder, "B\n", &error)) << error;
  std::ofstream(store.ItemPath(1, "txt")) << "B's";
  ASSERT_TRUE(RemoveDirectory(folder, &error)) << error;
  ASSERT_TRUE(store.Open(folder, "A\n", &error)) << error;
  EXPECT_EQ(ReadWholeFile(folder + "/0000.txt"), "A's fit");
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
