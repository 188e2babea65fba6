// The last few entries an op built for a tensor it is called with again and
// again (a mesh's triangle list), most recent first (internal). Each entry
// holds the stamp of the tensor it was built for (ops/render/tensor_stamp.h);
// entries whose tensor was freed or written since are dropped at the next
// look-up. Thread-safe: each call holds the lock for its own work only, so
// building an entry happens outside it (two threads may build the same one).
// Used by vertex_normals' corner lists and antialias's welded topologies.
#pragma once

#include <algorithm>
#include <cstddef>
#include <mutex>
#include <optional>
#include <vector>

#include "ops/render/tensor_stamp.h"

namespace gr::detail {

// Entry: copyable, with a member `TensorStamp stamp`.
template <class Entry, std::size_t kEntries = 4>
class RecentEntries {
 public:
  // Copies of the live entries `match` accepts, most recent first.
  template <class Match>
  std::vector<Entry> all(Match match) {
    std::lock_guard<std::mutex> lock(mutex_);
    drop_stale();
    std::vector<Entry> found;
    for (const Entry& e : entries_)
      if (match(e)) found.push_back(e);
    return found;
  }

  // The most recent live entry `match` accepts, made the most recent; none if none.
  template <class Match>
  std::optional<Entry> find(Match match) {
    std::lock_guard<std::mutex> lock(mutex_);
    drop_stale();
    return take_front(match);
  }

  // The entry `match` accepts if one is kept (made the most recent), else
  // `made`, kept as the most recent (the oldest beyond kEntries dropped).
  template <class Match>
  Entry find_or_keep(Match match, Entry made) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (std::optional<Entry> kept = take_front(match)) return *kept;
    entries_.insert(entries_.begin(), made);
    if (entries_.size() > kEntries) entries_.pop_back();
    return made;
  }

 private:
  void drop_stale() {
    entries_.erase(std::remove_if(entries_.begin(), entries_.end(), [](const Entry& e) { return e.stamp.stale(); }),
                   entries_.end());
  }

  template <class Match>
  std::optional<Entry> take_front(Match match) {
    for (std::size_t i = 0; i < entries_.size(); ++i)
      if (match(entries_[i])) {
        std::rotate(entries_.begin(), entries_.begin() + i, entries_.begin() + i + 1);
        return entries_.front();
      }
    return std::nullopt;
  }

  std::mutex mutex_;
  std::vector<Entry> entries_;
};

}  // namespace gr::detail
