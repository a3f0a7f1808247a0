import { useSettingsStore } from '@/stores/settingsStore';

/** Speak a `speak` sentence with the browser's TTS when the brain's speech output is the browser. */
export function speak(text: string): void {
  const { config, muted } = useSettingsStore.getState();
  if (!config?.speech_output_browser || muted || typeof speechSynthesis === 'undefined') return;
  speechSynthesis.speak(new SpeechSynthesisUtterance(text));
}

/** speech_interrupted / mute: drop the queue and stop talking now. */
export function silence(): void {
  if (typeof speechSynthesis !== 'undefined') speechSynthesis.cancel();
}
