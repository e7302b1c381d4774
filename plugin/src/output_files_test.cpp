// Tests of the all-or-nothing output files (output_files.h).
#include "output_files.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>

namespace filmgrain::cli {
namespace {

namespace fs = std::filesystem;

class OutputFilesTest : public ::testing::Test {
protected:
    void SetUp() override
    {
        m_dir = fs::temp_directory_path()
                / ("filmgrain_output_files_test_" + std::to_string(::getpid()));
        fs::remove_all(m_dir);
        fs::create_directories(m_dir);
    }
    void TearDown() override { fs::remove_all(m_dir); }
    size_t count_files() const
    {
        return static_cast<size_t>(std::distance(fs::directory_iterator(m_dir),
                                                 fs::directory_iterator()));
    }
    std::string path(const char* name) const { return (m_dir / name).string(); }
    fs::path m_dir;
};

TEST_F(OutputFilesTest, TempNameIsHiddenBesideTheOutput)
{
    EXPECT_EQ(OutputFiles::temp_path_for("out/a.exr"),
              "out/.a.exr.tmp-" + std::to_string(::getpid()));
    EXPECT_EQ(OutputFiles::temp_path_for("a.exr"), ".a.exr.tmp-" + std::to_string(::getpid()));
}

TEST_F(OutputFilesTest, CommitRenamesEverything)
{
    OutputFiles files;
    std::string t1, t2;
    ASSERT_TRUE(files.reserve(path("a.exr"), t1).ok());
    ASSERT_TRUE(files.reserve(path("b.json"), t2).ok());
    std::ofstream(t1) << "a";
    EXPECT_FALSE(fs::exists(path("a.exr")));
    ASSERT_TRUE(files.commit().ok());
    EXPECT_TRUE(fs::exists(path("a.exr")));
    EXPECT_TRUE(fs::exists(path("b.json")));
    EXPECT_EQ(count_files(), 2u);
}

TEST_F(OutputFilesTest, DestructionWithoutCommitLeavesNothing)
{
    {
        OutputFiles files;
        std::string t;
        ASSERT_TRUE(files.reserve(path("a.exr"), t).ok());
        std::ofstream(t) << "partial";
        EXPECT_EQ(count_files(), 1u);
    }
    EXPECT_EQ(count_files(), 0u);
}

TEST_F(OutputFilesTest, MissingDirectoryFailsAtReserve)
{
    OutputFiles files;
    std::string t;
    const Status s = files.reserve(path("no/such/dir/a.exr"), t);
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.message().find("cannot write"), std::string::npos) << s.message();
}

TEST_F(OutputFilesTest, FailedCommitTakesBackWhatItRenamed)
{
    OutputFiles files;
    std::string t1, t2;
    ASSERT_TRUE(files.reserve(path("a.exr"), t1).ok());
    ASSERT_TRUE(files.reserve(path("b.json"), t2).ok());
    // A non-empty directory where the second output should go: rename fails.
    fs::create_directories(path("b.json"));
    std::ofstream(fs::path(path("b.json")) / "x") << "x";
    EXPECT_FALSE(files.commit().ok());
    EXPECT_FALSE(fs::exists(path("a.exr")));
    EXPECT_FALSE(fs::exists(t1));
}

}  // namespace
}  // namespace filmgrain::cli
