// The documentation against the code: every knob of the settings table has its row in
// docs/cli.md (with its choices) and its key in docs/scene-format.md; the README stays a
// newcomer's page (at most 250 lines, linking to docs/cli.md); the user's pages carry no
// issue numbers; and their relative links point at files that exist, their anchors at
// headings that exist.
//
// While the new README is being written as docs/README.new.md (its links written from the
// repository's root, as they will be once it replaces README.md), the README checks apply
// to it; once it has replaced README.md, to README.md.
#include <gtest/gtest.h>

#include <cctype>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "lightmesh/settings/render_settings.h"

namespace lm {
namespace docs_test {
namespace {

namespace fs = std::filesystem;

// The repository's root: the folder of the README the build names.
fs::path RepoRoot() { return fs::path(LIGHTMESH_README).parent_path(); }

std::string ReadText(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

std::vector<std::string> Lines(const std::string& text) {
    std::vector<std::string> lines;
    size_t begin = 0;
    while (begin < text.size()) {
        size_t end = text.find('\n', begin);
        if (end == std::string::npos) end = text.size();
        lines.push_back(text.substr(begin, end - begin));
        begin = end + 1;
    }
    return lines;
}

// The README a newcomer reads: docs/README.new.md until it replaces README.md.
fs::path NewcomersReadme() {
    const fs::path draft = RepoRoot() / "docs" / "README.new.md";
    return fs::exists(draft) ? draft : RepoRoot() / "README.md";
}

// The pages of the user's manual (docs/performance-history.md, the measurement log, may
// name issues; docs/bench/ holds generated tables).
std::vector<fs::path> ManualPages() {
    std::vector<fs::path> pages;
    for (const char* name : {"cli.md", "scene-format.md", "method.md", "backends.md", "benchmarks.md",
                             "robustness.md", "development.md", "soft-shadows.md", "denoised-shadows.md"}) {
        const fs::path p = RepoRoot() / "docs" / name;
        if (fs::exists(p)) pages.push_back(p);
    }
    return pages;
}

TEST(Docs, TheCliPageDocumentsEveryRenderSetting) {
    const fs::path cli = RepoRoot() / "docs" / "cli.md";
    if (!fs::exists(cli)) GTEST_SKIP() << cli << " does not exist yet";
    const std::vector<std::string> lines = Lines(ReadText(cli));
    for (const RenderSetting& s : RenderSettings()) {
        SCOPED_TRACE(s.flag);
        // Its row in a table: "| `--flag …` | default | range or choices | …".
        const std::string start = std::string("| `") + s.flag;
        const std::string* row = nullptr;
        for (const std::string& line : lines)
            if (line.rfind(start, 0) == 0 && (line.size() == start.size() || line[start.size()] == ' ' ||
                                              line[start.size()] == '`' || line[start.size()] == ',')) {
                row = &line;
                break;
            }
        ASSERT_NE(row, nullptr) << "docs/cli.md has no table row starting with " << start;
        for (const std::string& choice : s.choices)
            EXPECT_NE(row->find("`" + choice + "`"), std::string::npos)
                << "docs/cli.md's row of " << s.flag << " does not name the choice `" << choice << "`";
    }
}

TEST(Docs, TheSceneFormatPageDocumentsEveryRenderKey) {
    const fs::path format = RepoRoot() / "docs" / "scene-format.md";
    if (!fs::exists(format)) GTEST_SKIP() << format << " does not exist yet";
    const std::string text = ReadText(format);
    for (const RenderSetting& s : RenderSettings())
        EXPECT_NE(text.find(std::string("`") + s.key + "`"), std::string::npos)
            << "docs/scene-format.md does not name the render key `" << s.key << "`";
}

TEST(Docs, TheReadmeIsShortAndLinksToTheCliPage) {
    const fs::path readme = NewcomersReadme();
    const std::string text = ReadText(readme);
    ASSERT_FALSE(text.empty()) << readme;
    const bool draft = readme.filename() == "README.new.md";
    // Before the swap README.md is the old, long one: only the draft is held to the limit.
    EXPECT_LE(Lines(text).size(), 250u) << readme << " is longer than 250 lines";
    if (fs::exists(RepoRoot() / "docs" / "cli.md")) {
        EXPECT_NE(text.find("docs/cli.md"), std::string::npos)
            << readme << " does not link to docs/cli.md" << (draft ? " (written from the repository's root)" : "");
    }
}

TEST(Docs, UserPagesNameNoIssues) {
    std::vector<fs::path> pages = ManualPages();
    pages.push_back(NewcomersReadme());
    const std::regex issue(R"((^|[^A-Za-z])[Ii]ssues? #?[0-9]+)");
    for (const fs::path& page : pages) {
        const std::vector<std::string> lines = Lines(ReadText(page));
        for (size_t i = 0; i < lines.size(); ++i)
            EXPECT_FALSE(std::regex_search(lines[i], issue))
                << page.filename().string() << ":" << i + 1 << " names an issue: " << lines[i];
    }
}

// GitHub's anchor of a heading: lower case (ASCII and Cyrillic), spaces to hyphens, other
// punctuation dropped; letters, digits, '-' and '_' kept.
std::string Anchor(const std::string& heading) {
    std::string a;
    for (size_t i = 0; i < heading.size(); ++i) {
        const unsigned char c = static_cast<unsigned char>(heading[i]);
        if (c < 0x80) {
            if (std::isalnum(c) || c == '-' || c == '_') a += static_cast<char>(std::tolower(c));
            else if (c == ' ') a += '-';
            continue;
        }
        // A UTF-8 sequence: Cyrillic letters (U+0400–U+04FF) are kept, lowered; others dropped.
        const size_t length = c >= 0xF0 ? 4 : c >= 0xE0 ? 3 : 2;
        if ((c == 0xD0 || c == 0xD1) && i + 1 < heading.size()) {
            unsigned cp = ((c & 0x1Fu) << 6) | (static_cast<unsigned char>(heading[i + 1]) & 0x3Fu);
            if (cp >= 0x410 && cp <= 0x42F) cp += 0x20;
            else if (cp >= 0x400 && cp <= 0x40F) cp += 0x50;
            a += static_cast<char>(0xC0 | (cp >> 6));
            a += static_cast<char>(0x80 | (cp & 0x3F));
        }
        i += length - 1;
    }
    return a;
}

std::set<std::string> Anchors(const fs::path& page) {
    std::set<std::string> anchors;
    bool fenced = false;
    for (const std::string& line : Lines(ReadText(page))) {
        if (line.rfind("```", 0) == 0) fenced = !fenced;
        if (fenced || line.empty() || line[0] != '#') continue;
        const size_t text = line.find_first_not_of('#');
        if (text == std::string::npos || line[text] != ' ') continue;
        std::string a = Anchor(line.substr(text + 1));
        // A repeated heading gets -1, -2, ….
        std::string unique = a;
        for (int n = 1; anchors.count(unique); ++n) unique = a + "-" + std::to_string(n);
        anchors.insert(unique);
    }
    return anchors;
}

TEST(Docs, RelativeLinksPointAtWhatExists) {
    // Each page with the folder its links are relative to: the draft README's are written
    // from the repository's root.
    std::vector<std::pair<fs::path, fs::path>> pages;
    for (const fs::path& p : ManualPages()) pages.push_back({p, p.parent_path()});
    pages.push_back({NewcomersReadme(), RepoRoot()});
    const std::regex link(R"(\]\(([^)\s]+)\))");
    for (const auto& [page, base] : pages) {
        const std::string text = ReadText(page);
        for (auto it = std::sregex_iterator(text.begin(), text.end(), link); it != std::sregex_iterator(); ++it) {
            const std::string target = (*it)[1];
            if (target.find("://") != std::string::npos || target.rfind("mailto:", 0) == 0) continue;
            const size_t hash = target.find('#');
            const std::string file = target.substr(0, hash);
            const fs::path resolved = file.empty() ? page : base / file;
            SCOPED_TRACE(page.filename().string() + ": " + target);
            if (!fs::exists(resolved)) {
                ADD_FAILURE() << resolved << " does not exist";
                continue;
            }
            if (hash == std::string::npos || resolved.extension() != ".md") continue;
            const std::string anchor = target.substr(hash + 1);
            EXPECT_TRUE(Anchors(resolved).count(anchor)) << resolved.filename() << " has no heading #" << anchor;
        }
    }
}

}  // namespace
}  // namespace docs_test
}  // namespace lm
