from robot_mcp_memory.query import (
    MAX_QUERY_WORDS,
    QueryTerm,
    build_query,
    concepts,
    document_concepts,
    query_terms,
    stem,
    words,
)


def test_words_are_lowercase_and_stripped_of_syntax() -> None:
    assert words('Fetch "the" PACKAGE* -now (NEAR)') == ["fetch", "the", "package", "now", "near"]


def test_stop_words_are_dropped_and_synonym_words_bring_their_concept() -> None:
    query = build_query("Could you please bring me the parcel and a xylophone?")

    assert query.words == ("bring", "parcel", "xylophone")
    assert query.concepts == ("synfetch", "synpackage")
    assert query.concept_weight == 1.0


def test_every_member_of_a_group_shares_one_concept() -> None:
    assert concepts("fetch bring retrieve pick up") == ["synfetch"] * 4
    assert concepts("packages parcels") == ["synpackage", "synpackage"]
    assert concepts("delivering carried") == ["syndeliver", "syndeliver"]


def test_a_written_out_multi_word_synonym_is_one_term() -> None:
    query = build_query("drop it at the post room")

    assert query.words == ("drop", "post room")
    assert query.concepts == ("syndeliver", "synmailroom")
    assert concepts("the mail room") == ["synmailroom"]


def test_document_concepts_cover_title_pattern_and_tags_but_not_the_body() -> None:
    text = document_concepts("Fetch mail", "from the lobby", ("lift",), "wait at the door")

    assert text.split() == ["synfetch", "synpackage", "synreception", "synelevator"]


def test_synonyms_can_be_turned_off() -> None:
    query = build_query("bring the parcel", synonyms=False)

    assert query.words == ("bring", "parcel")
    assert query.concepts == ()


def test_a_query_of_only_stop_words_keeps_them() -> None:
    assert build_query("what is this").words == ("what", "is", "this")


def test_a_query_without_word_characters_is_empty() -> None:
    assert build_query('"* - ()"').empty
    assert build_query("").empty
    assert not build_query("mailroom").empty


def test_long_queries_are_capped_and_repeated_words_count_once() -> None:
    text = " ".join(f"word{index}" for index in range(100))

    assert len(build_query(text).words) == MAX_QUERY_WORDS
    assert build_query("mailroom mailroom").words == ("mailroom",)


def test_synonyms_match_any_inflection_through_snowball_stems() -> None:
    assert stem("deliveries") == stem("delivery")
    assert concepts("refrigerators") == ["synfridge"]
    assert concepts("the receptionists") == ["synreceptionist"]
    assert concepts("loading bays") == ["synloadingdock"]


def test_contraction_fragments_are_stop_words() -> None:
    assert build_query("there's the boss's parcel, don't drop it").words == (
        "boss",
        "parcel",
        "drop",
    )


def test_query_terms_carry_stems_and_concepts() -> None:
    assert query_terms("please pick up the parcels") == [
        QueryTerm("pick up", ("pick", "up"), "synfetch"),
        QueryTerm("parcels", ("parcel",), "synpackage"),
    ]
