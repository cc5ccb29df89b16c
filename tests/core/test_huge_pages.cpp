// prefer_huge_pages (core/huge_pages.h): which bytes it advises (the whole
// 2 MiB pages inside the range, worked out here from the address), that the
// contents stay as they were, and that what it reports collapsed is mapped
// with huge pages in /proc/self/smaps.

#include "core/huge_pages.h"
#include "common/huge_pages_support.h"

#include <gtest/gtest.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace palpa::core {
namespace {

using test::first_whole_huge_page;
using test::huge_kb_of_mapping_holding;
using test::thp_setting;
using test::whole_huge_pages;

std::vector<std::uint64_t> pattern(std::size_t count) {
  std::vector<std::uint64_t> v(count);
  for (std::size_t i = 0; i < count; ++i) v[i] = i * 0x9E3779B97F4A7C15ull;
  return v;
}

TEST(HugePages, AdvisesTheWholeHugePagesInsideTheRangeAndKeepsTheContents) {
  // 9 MiB and a bit: three to four whole huge pages, by where it starts.
  const std::size_t count = (9u << 20) / 8 + 3;
  std::vector<std::uint64_t> v = pattern(count);
  const std::vector<std::uint64_t> copy = v;
  const HugePageAdvice a = prefer_huge_pages(v);
  const std::size_t expected = whole_huge_pages(v.data(), count * 8);
  ASSERT_GE(expected, 3 * kHugePageBytes);
  const std::string setting = thp_setting();
  EXPECT_EQ(huge_page_setting(), setting);
  if (setting.empty() || setting == "never") {
    // No THP in the kernel, or the administrator's "never": nothing asked.
    EXPECT_FALSE(huge_pages_allowed());
    EXPECT_EQ(a.advised, 0u) << "transparent huge pages are '" << setting << "'";
  } else {
    EXPECT_TRUE(huge_pages_allowed());
    EXPECT_EQ(a.advised, expected) << "madvise(MADV_HUGEPAGE) refused (errno " << errno << ", "
                                   << std::strerror(errno) << ") though transparent huge pages are '" << setting
                                   << "'";
  }
  EXPECT_TRUE(a.collapsed == 0 || a.collapsed == a.advised);
  EXPECT_EQ(v, copy);
  // Asking again changes nothing either.
  const HugePageAdvice again = prefer_huge_pages(v);
  EXPECT_EQ(again.advised, a.advised);
  EXPECT_EQ(v, copy);
}

TEST(HugePages, RangesWithoutAWholeHugePageAreLeftAlone) {
  EXPECT_EQ(prefer_huge_pages(nullptr, 64u << 20).advised, 0u);
  const std::vector<std::uint64_t> small = pattern((1u << 20) / 8);  // 1 MiB
  EXPECT_EQ(prefer_huge_pages(small).advised, 0u);
  EXPECT_EQ(prefer_huge_pages(std::vector<int>{}).advised, 0u);
  // 2 MiB and a byte, starting one byte past a huge page boundary inside a
  // larger array: no whole page.
  std::vector<char> big(8u << 20);
  const std::uintptr_t boundary = first_whole_huge_page(big.data());
  const HugePageAdvice off = prefer_huge_pages(reinterpret_cast<const void*>(boundary + 1), kHugePageBytes + 1);
  EXPECT_EQ(off.advised, 0u);
  EXPECT_EQ(off.collapsed, 0u);
}

TEST(HugePages, WhatItReportsCollapsedIsMappedWithHugePages) {
  const std::size_t count = (9u << 20) / 8;
  const std::vector<std::uint64_t> v = pattern(count);
  const HugePageAdvice a = prefer_huge_pages(v);
  if (a.collapsed == 0) {
    GTEST_SKIP() << "the kernel collapsed nothing here (it needs Linux 6.1, free huge pages and a THP setting "
                    "other than 'never'; transparent huge pages are '"
                 << thp_setting() << "'), so there is no mapping to check";
  }
  // The advice gives the advised bytes a mapping of their own, or one
  // shared with advised neighbours: it holds at least the collapsed bytes
  // in huge pages.
  const std::uintptr_t first = first_whole_huge_page(v.data());
  const long kb = huge_kb_of_mapping_holding(first, first + a.collapsed);
  ASSERT_GE(kb, 0) << "no mapping of /proc/self/smaps holds the advised bytes";
  EXPECT_GE(static_cast<std::size_t>(kb) * 1024, a.collapsed);
}

}  // namespace
}  // namespace palpa::core
