#ifndef AQS_UTIL_KEYED_STORE_H_
#define AQS_UTIL_KEYED_STORE_H_

#include <string>

namespace aqs {

// A folder of results kept as a long job makes them (one item per pose, frame or
// target, numbered), so that a rerun after a stop takes the items already done:
//
//   key.txt                what the items belong to (the caller's text: model
//                          fingerprints, options); written when the store is opened
//   NNNN.<extension>       item NNNN's files (the caller's; each written atomically, the
//                          one that marks the item whole last)
//
// Used by aqs_prepare's volumetric targets (prepare/target_store.h) and aqs_evaluate's
// held-out fits (jobs/held_out_fit_store.h).
class KeyedStore {
 public:
  // Opens `directory` (created with its parents if missing) for `key`. A folder that
  // holds another key (or none, or an unreadable one) is moved aside first, to
  // PreviousPath(directory) (replacing what an earlier such move left there): its items
  // belong to something else, and a rerun with other options (a mistyped flag) must not
  // delete them before it has made anything; the caller removes that folder with its
  // own once the job is done. Where the folder moved aside holds `key` (this run's, back
  // after a run with another key), the two trade places instead: that run's items are
  // taken back. Returns false with *error (naming the path) if the folder cannot be made
  // or moved, or key.txt cannot be written.
  bool Open(const std::string& directory, const std::string& key, std::string* error);

  // Where Open moves a store of another key: directory + ".previous".
  static std::string PreviousPath(const std::string& directory);

  bool is_open() const { return !directory_.empty(); }
  const std::string& directory() const { return directory_; }

  // directory/NNNN.extension (index zero-padded to 4 digits, wider above 9999).
  std::string ItemPath(int index, const char* extension) const;

 private:
  std::string directory_;
};

}  // namespace aqs

#endif  // AQS_UTIL_KEYED_STORE_H_
