// The CSV tokenizer (spectral/include/skinspec/spectral/csv.hpp) on its own: quoting, line ends,
// the lines each row and cell start on, and the defects it refuses with their line.

#include "skinspec/spectral/csv.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace skinspec::csv {
namespace {

// Every row's cells as text, or the error.
std::expected<std::vector<std::vector<std::string>>, Error> cells_of(std::string_view bytes,
                                                                     LoneCr lone_cr = LoneCr::refused) {
  Reader reader(bytes, lone_cr);
  std::vector<std::vector<std::string>> rows;
  while (reader.peek()) {
    const auto row = reader.read_row();
    if (!row) return std::unexpected(row.error());
    auto& cells = rows.emplace_back();
    for (const auto& cell : row->cells) cells.emplace_back(cell.text);
  }
  return rows;
}

using Rows = std::vector<std::vector<std::string>>;

TEST(CsvTest, PlainCellsKeepTheirBlanksAndEmptyOnes) {
  EXPECT_EQ(cells_of("a, b ,,c\n1,2"), (Rows{{"a", " b ", "", "c"}, {"1", "2"}}));
}

TEST(CsvTest, QuotedCommasStayInTheirCell) {
  EXPECT_EQ(cells_of("\"left, cheek\",0.1\n"), (Rows{{"left, cheek", "0.1"}}));
}

TEST(CsvTest, DoubledQuotesInsideQuotesAreOneQuote) {
  EXPECT_EQ(cells_of("\"say \"\"cheek\"\"\",\"\"\"\"\n"), (Rows{{"say \"cheek\"", "\""}}));
  // Text around the quotes is kept with them.
  EXPECT_EQ(cells_of(" \"a\"b,x\n"), (Rows{{" ab", "x"}}));
}

TEST(CsvTest, CrlfEndsALineAsLfDoes) {
  EXPECT_EQ(cells_of("a,b\r\n1,2\r\n"), (Rows{{"a", "b"}, {"1", "2"}}));
  Reader reader("a,b\r\n\r\n1,2\r\n");
  ASSERT_TRUE(reader.read_row());
  const auto second = reader.read_row();
  ASSERT_TRUE(second);
  EXPECT_EQ(second->line, 3u);  // the blank line between is passed over, and counted
  EXPECT_EQ(second->bytes, "1,2");
}

TEST(CsvTest, ALoneCarriageReturnIsRefusedOrEndsALineAsTold) {
  const auto refused = cells_of("a,b\r1,2\n");
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().line, 1u);
  EXPECT_NE(refused.error().message.find("carriage return alone"), std::string::npos);
  EXPECT_EQ(cells_of("a,b\r1,2\r", LoneCr::ends_line), (Rows{{"a", "b"}, {"1", "2"}}));
  // Inside quotes it is text, either way.
  EXPECT_EQ(cells_of("\"a\rb\"\n"), (Rows{{"a\rb"}}));
}

TEST(CsvTest, AQuotedNewlineIsTextAndTheLinesAfterItAreCountedRight) {
  Reader reader("id,note\n1,\"first\nsecond\"\n2,x,\"y\r\nz\",w\n3\n");
  std::vector<Row> rows;
  while (reader.peek()) {
    auto row = reader.read_row();
    ASSERT_TRUE(row) << row.error().message;
    rows.push_back(std::move(*row));
  }
  ASSERT_EQ(rows.size(), 4u);
  EXPECT_EQ(rows[1].line, 2u);
  EXPECT_EQ(rows[1].cells[1].text, "first\nsecond");
  EXPECT_EQ(rows[1].bytes, "1,\"first\nsecond\"");
  EXPECT_EQ(rows[2].line, 4u);
  EXPECT_EQ(rows[2].cells[2].text, "y\r\nz");
  // A cell after the quoted line end is placed on its own line.
  EXPECT_EQ(rows[2].cells[3].line, 5u);
  EXPECT_EQ(rows[2].cells[3].column, 4u);
  EXPECT_EQ(rows[3].line, 6u);
}

TEST(CsvTest, CellsSayWhereTheyStart) {
  Reader reader("\n  a,\"b\", c\n");
  const auto row = reader.read_row();
  ASSERT_TRUE(row);
  EXPECT_EQ(row->line, 2u);
  ASSERT_EQ(row->cells.size(), 3u);
  EXPECT_EQ(row->cells[0].column, 1u);
  EXPECT_EQ(row->cells[1].column, 5u);
  EXPECT_EQ(row->cells[2].column, 9u);
  EXPECT_EQ(row->cells[2].line, 2u);
}

TEST(CsvTest, AnUnterminatedQuoteIsRefusedWithTheLineItOpensOn) {
  const auto open = cells_of("a,b\n\n1,\"2\n3,4\n");
  ASSERT_FALSE(open);
  EXPECT_EQ(open.error().line, 3u);
  EXPECT_EQ(open.error().message, "a quoted field is not closed");
}

TEST(CsvTest, CallersSkipTheLinesThatAreNotCsv) {
  Reader reader(" \t\n# a \"comment, unparsed\n\"x\",y\n");
  const auto comment = reader.peek();
  ASSERT_TRUE(comment);
  EXPECT_EQ(comment->number, 2u);
  EXPECT_EQ(comment->text, "# a \"comment, unparsed");
  reader.skip_line();
  const auto row = reader.read_row();
  ASSERT_TRUE(row);
  EXPECT_EQ(row->line, 3u);
  EXPECT_EQ(row->cells[0].text, "x");
  EXPECT_FALSE(reader.peek());
}

TEST(CsvTest, BlankInputHasNoRows) {
  EXPECT_EQ(cells_of(""), Rows{});
  EXPECT_EQ(cells_of(" \n\t\r\n"), Rows{});
}

}  // namespace
}  // namespace skinspec::csv
