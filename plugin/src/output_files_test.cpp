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

TEST_F(OutputFilesTest, ReserveLeavesNothingAndCommitPlacesEverything)
{
    OutputFiles files;
    ASSERT_TRUE(files.reserve(path("a.exr")).ok());
    ASSERT_TRUE(files.reserve(path("b.json")).ok());
    EXPECT_EQ(count_files(), 0u) << "reserve must not create a file (SIGKILL would leave it)";
    std::FILE* f = nullptr;
    ASSERT_TRUE(files.open(path("a.exr"), f).ok());
    std::fputs("a", f);
    std::fclose(f);
    ASSERT_TRUE(files.write(path("b.json"), "{}\n").ok());
    EXPECT_FALSE(fs::exists(path("a.exr")));
    ASSERT_TRUE(files.commit().ok());
    EXPECT_EQ(count_files(), 2u);
    std::string a, b;
    std::ifstream(path("a.exr")) >> a;
    std::ifstream(path("b.json")) >> b;
    EXPECT_EQ(a, "a");
    EXPECT_EQ(b, "{}");
}

TEST_F(OutputFilesTest, CommitReplacesAnExistingOutput)
{
    std::ofstream(path("a.exr")) << "old";
    OutputFiles files;
    ASSERT_TRUE(files.reserve(path("a.exr")).ok());
    ASSERT_TRUE(files.write(path("a.exr"), "new").ok());
    ASSERT_TRUE(files.commit().ok());
    std::string a;
    std::ifstream(path("a.exr")) >> a;
    EXPECT_EQ(a, "new");
    EXPECT_EQ(count_files(), 1u);
}

TEST_F(OutputFilesTest, DestructionWithoutCommitLeavesNothing)
{
    {
        OutputFiles files;
        ASSERT_TRUE(files.reserve(path("a.exr")).ok());
        ASSERT_TRUE(files.write(path("a.exr"), "partial").ok());
    }
    EXPECT_EQ(count_files(), 0u);
}

TEST_F(OutputFilesTest, MissingDirectoryFailsAtReserve)
{
    OutputFiles files;
    const Status s = files.reserve(path("no/such/dir/a.exr"));
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.message().find("cannot write"), std::string::npos) << s.message();
}

TEST_F(OutputFilesTest, MisuseIsAnError)
{
    OutputFiles files;
    std::FILE* f = nullptr;
    EXPECT_FALSE(files.open(path("a.exr"), f).ok());  // not reserved
    ASSERT_TRUE(files.reserve(path("a.exr")).ok());
    EXPECT_FALSE(files.reserve(path("a.exr")).ok());
    EXPECT_FALSE(files.commit().ok());  // reserved, never written
    ASSERT_TRUE(files.write(path("a.exr"), "x").ok());
    EXPECT_FALSE(files.write(path("a.exr"), "y").ok());  // twice
}

TEST_F(OutputFilesTest, FailedCommitTakesBackWhatItPlaced)
{
    OutputFiles files;
    ASSERT_TRUE(files.reserve(path("a.exr")).ok());
    ASSERT_TRUE(files.reserve(path("b.json")).ok());
    ASSERT_TRUE(files.write(path("a.exr"), "a").ok());
    ASSERT_TRUE(files.write(path("b.json"), "b").ok());
    // A non-empty directory where the second output should go: rename fails.
    fs::create_directories(path("b.json"));
    std::ofstream(fs::path(path("b.json")) / "x") << "x";
    EXPECT_FALSE(files.commit().ok());
    EXPECT_FALSE(fs::exists(path("a.exr")));
    EXPECT_EQ(count_files(), 1u);  // only the directory
}

}  // namespace
}  // namespace filmgrain::cli
