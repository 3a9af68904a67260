"""The grading kit: question files (TOML), reference answers from raycastd, tolerances, partial
credit, feedback, and Gradescope / PrairieLearn / text results (clients/grading/README.md)."""

from raycastd.grading.grader import (
    Answers,
    Grader,
    QuestionResult,
    Report,
    grade_files,
    load_answers,
)
from raycastd.grading.questions import Question, QuestionFileError, QuestionSet, load_questions
from raycastd.grading.tolerance import Tolerance

__all__ = [
    "Answers",
    "Grader",
    "Question",
    "QuestionFileError",
    "QuestionResult",
    "QuestionSet",
    "Report",
    "Tolerance",
    "grade_files",
    "load_answers",
    "load_questions",
]
