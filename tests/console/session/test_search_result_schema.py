"""The search result's published schema (docs/schemas/search_result.schema.json) holds every field of the result,
and the recording's /search/result schema is the same with the search's id (`contacts` was missing there)."""

from __future__ import annotations

import dataclasses
import json

from console.recording import recording_schemas as rs
from console.recording.channel_schemas import CHANNEL_SCHEMAS
from console.schemas import SCHEMAS
from console.session.search_report import result_event
from console.session.search_types import SearchResult
from pipeline.schema_check import schema_errors


def test_the_schema_has_every_field_of_the_result_and_no_other() -> None:
    fields = [f.name for f in dataclasses.fields(SearchResult)]
    schema = SCHEMAS["search_result"]
    assert list(schema["properties"]) == fields and schema["required"] == fields
    recorded = CHANNEL_SCHEMAS[rs.SEARCH_RESULT]
    assert set(recorded["properties"]) == {"search_id", *fields} and "contacts" in recorded["required"]


def test_results_validate_and_bad_ones_are_named() -> None:
    r = SearchResult(found=True, target="robot dog", target_id="robot_dog-1", target_position=[2.5, 6.9, 0.2],
                     seen_by=["c1", "c2"], final_position=[2.4, 6.2, 0.0], distance_to_target=0.7, path_length=9.5,
                     captures=4, time=120.0, reason="found robot_dog-1 at 0.70 m", seen_share=0.6, battery=0.8,
                     choose_seconds=[0.02], contacts=1, steps=["start"])
    data = json.loads(r.to_json())
    assert schema_errors(SCHEMAS["search_result"], data) == []
    assert schema_errors(CHANNEL_SCHEMAS[rs.SEARCH_RESULT], result_event("s1", r)) == []
    assert schema_errors(SCHEMAS["search_result"], json.loads(SearchResult(target="robot dog").to_json())) == []
    for bad in ({**data, "contacts": -1}, {**data, "seen_share": 1.5}, {k: v for k, v in data.items() if k != "contacts"},
                {**data, "extra": 1}):
        assert schema_errors(SCHEMAS["search_result"], bad), bad
    assert schema_errors(CHANNEL_SCHEMAS[rs.SEARCH_RESULT], {k: v for k, v in result_event("s1", r).items()
                                                            if k != "contacts"})
