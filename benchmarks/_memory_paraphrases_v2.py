"""A second, larger paraphrase set for the memory benchmark (70 queries, 2 per target of
:mod:`_memory_paraphrases`). Written before any recall work of issue 15, in other words than the
first set's queries (no query shares its wording), the way operators phrase requests: short
commands, polite questions, indirect needs, names and room numbers. Used only to measure: the
synonym list and query expansion were not tuned on it."""

from __future__ import annotations

QUERIES: dict[str, tuple[str, ...]] = {
    "fetch-package-from-mailroom": (
        "there's a box for me at the mail room, can you bring it up",
        "pick up my shipment from the post office downstairs",
    ),
    "deliver-documents-to-finance": (
        "drop these invoices off at the accounting department",
        "bring the signed paperwork to finance",
    ),
    "water-office-plants": (
        "the office greenery needs watering",
        "can you give the potted plants a drink",
    ),
    "evening-security-patrol": (
        "walk the corridors tonight and check the windows",
        "do the night-time security rounds",
    ),
    "escort-visitor-to-meeting-room": (
        "lead the guest waiting in the foyer to meeting room 2",
        "take our visitor up to the conference room please",
    ),
    "bring-coffee-to-desk": (
        "get me a fresh coffee from the kitchen",
        "fetch a mug of coffee and put it on my desk",
    ),
    "return-to-charging-dock": (
        "time to recharge, head back to your dock",
        "go charge your battery at the station",
    ),
    "find-lost-keys": (
        "I misplaced my keys somewhere in the office, search for them",
        "where did my key ring go? please look around",
    ),
    "take-trash-to-bins": (
        "bring the rubbish bags out to recycling",
        "throw the waste in the outdoor bins",
    ),
    "check-meeting-room-free": (
        "is anyone using the meeting room at the moment",
        "find out whether the conference room is available",
    ),
    "deliver-medication-to-patient": (
        "bring the patient in room 4 their medicine",
        "deliver the prescription to the ward room on schedule",
    ),
    "collect-printouts": (
        "grab my print job off the printer",
        "fetch the pages I sent to the printer",
    ),
    "greet-guests-at-entrance": (
        "say hello to people coming in at the entrance",
        "be at the front entrance to receive arriving guests",
    ),
    "inventory-supply-closet": (
        "take stock of what is in the supply cupboard",
        "count the supplies in the storage room and tell me what is low",
    ),
    "deliver-lunch-to-meeting": (
        "the caterer dropped lunch at reception, take it to the meeting",
        "carry the meeting's food over to the boardroom",
    ),
    "open-door-for-courier": (
        "a courier is at the back door, let him in",
        "open the rear door for the parcel guy",
    ),
    "announce-fire-drill": (
        "announce the fire drill on all floors",
        "warn every floor that the fire alarm test is about to begin",
    ),
    "report-kitchen-spill": (
        "there's a puddle on the kitchen floor, warn people and call cleaning",
        "coffee got spilled in the pantry, get someone to mop it",
    ),
    "return-library-books": (
        "bring these books back to the library",
        "return the borrowed novels to the library shelves",
    ),
    "check-server-room-temperature": (
        "is the server room getting too warm? read the thermometer",
        "check the temperature in the server room",
    ),
    "follow-person-carrying-boxes": (
        "carry my boxes and follow me",
        "come with me and carry these boxes around the building",
    ),
    "remind-person-of-meeting": (
        "go remind Alex that his meeting starts soon",
        "tell Priya at her desk not to forget the 3pm meeting",
    ),
    "distribute-morning-mail": (
        "deliver the morning post to each desk",
        "hand out the mail to all the desks this morning",
    ),
    "photograph-whiteboard": (
        "take a photo of the whiteboard before they erase it",
        "capture the whiteboard notes from the meeting and send them to me",
    ),
    "refill-printer-paper": (
        "the printer has run out of paper, refill it",
        "load a fresh ream into the printer tray",
    ),
    "give-office-tour": (
        "give our new colleague a tour of the office",
        "walk the newcomer around and explain each area",
    ),
    "find-person-in-building": (
        "track down Tom somewhere in the building and tell him he's wanted",
        "search the floors for Dr. Lee, she is needed",
    ),
    "close-windows-at-night": (
        "close all the windows before we lock up tonight",
        "make sure every window is shut for the night",
    ),
    "bring-laptop-to-it-desk": (
        "my laptop died, drop it at the IT help desk",
        "take this broken computer to IT for repair",
    ),
    "receive-delivery-at-loading-dock": (
        "a truck is at the loading dock, check the pallets and sign for them",
        "go sign for the delivery arriving at the loading bay",
    ),
    "check-fridge-expired-food": (
        "check the kitchen fridge for food that has expired",
        "clear out anything out of date in the fridge and report it",
    ),
    "escort-visitor-to-exit": (
        "see our visitor out of the building",
        "guide the guest to the exit after their meeting",
    ),
    "drop-off-keys-at-reception": (
        "hand these keys to the receptionist",
        "drop the key set at reception",
    ),
    "report-broken-light": (
        "some corridor lights are out, report it to facilities",
        "a light in the hallway is broken, notify maintenance",
    ),
    "prepare-meeting-room": (
        "set up the meeting room: chairs in place and projector on",
        "arrange the boardroom chairs and turn on the beamer before the meeting",
    ),
}
